// Feature curves of a triangle mesh: sharp edges, open boundaries, non-manifold edges and
// borders between input entities, chained into curves with corners.
#pragma once
#include "engine/core/mesh.hpp"
#include "engine/core/topology.hpp"
#include "engine/curving/cone_points.hpp"
#include "engine/curving/exact_quadric.hpp"

#include <vector>

namespace hocurve {

struct FeatureOptions {
  double angle_deg = 35.0;         ///< an edge is sharp when its dihedral angle (between face normals) exceeds this
  /// Edges whose dihedral angle lies in [weak_angle_deg, angle_deg) are sharp when the surface
  /// around them has a kink of at least kink_angle_deg (and at least half their dihedral angle)
  /// along the edge line: a weighted least-squares fit of a quadric plus a |y| term (y across the
  /// edge) to the two-rings of both ends. A coarse smooth surface has large dihedral angles
  /// too but no kink: measured on Gmsh meshes of CAD parts and coarse analytic shapes (t20,
  /// screw, torus, ellipsoid, cylinder at h = diag/20..80 and 0.1-0.2), every CAD-face border in
  /// [20, 35) degrees was caught (their kinks: >= 19.5 degrees), 2 of 577 smooth edges in that
  /// band were not rejected (the others' kinks: <= 15.9 degrees); 18 sits between the two.
  /// The test's stencils do not cross the features found without it. weak_angle_deg >=
  /// angle_deg switches the test off; angle_deg = 180 turns off every dihedral-angle feature.
  double weak_angle_deg = 20.0;
  double kink_angle_deg = 18.0;
  /// A face with an angle above cap_angle_deg is a cap: its three corners are nearly collinear,
  /// so they hardly fix its normal (tilted by about the longest edge's sagitta over the height; a
  /// needle, whose largest angle is near 90 degrees, has its long edges on the surface). A cap
  /// whose normal differs by more than cap_tilt_deg from each of its edge neighbours' is
  /// unreliable (a cap in a fan of a flat face agrees with one, even on the face's rim). The
  /// edges of unreliable caps with a dihedral angle of at least weak_angle_deg are sharp only if
  /// the kink test (in the frame of the area-weighted normals around the edge) finds a kink of
  /// kink_angle_deg. Iso-surface meshes (marching tetrahedra of a sphere and a torus) have such
  /// caps: their face normals made 12 and 75 sharp edges where the surface is smooth (now 2 and
  /// 1), and P4 nodes up to 4e-3 off the sphere there (linear: 5e-3). A needle's normal is
  /// tilted alike where its height is below a 150 degree cap's (over its longest edge): one whose
  /// neighbours across both long sides contradict it is unreliable too, but only for the kink
  /// test's frame (an iso-surface torus at grid 24 had 2 false curves, P4 2.7e-3 -> 7.5e-4; its
  /// edges above angle_deg through the kink test as well took a CAD export, thingi10k_375236, 1.44
  /// -> 1.91% off the input).
  double cap_angle_deg = 150.0;
  double cap_tilt_deg = 10.0;
  /// An edge sharper than angle_deg but at most fillet_max_deg is smooth when it is the middle row
  /// of a fillet tessellated with two segments across (dihedral angles theta / 2, theta, theta / 2,
  /// flat beyond; e.g. a 90 degree fillet at 45 degrees per segment): taken sharp, each half of the
  /// fillet was fitted as a ruled band, off by the chord's sagitta. 0 turns it off.
  double fillet_max_deg = 65.0;
  double corner_angle_deg = 35.0;  ///< a vertex on a single curve is a corner when the curve turns more than this
  /// ... unless it turns by at most coarse_circle_max_deg about the same axis as both its curve
  /// neighbours, the sharper of them turning at least half and the straighter at least a third as
  /// much: a coarse circle (6 segments or more) or ellipse, as a coarse mesh has round a hole or a
  /// rim (a polygon's corners meet sharp side edges too, making them junctions anyway; a straight
  /// line meeting a circle is a corner). Measured: the CAD screw at d/40, its bottom rim 10
  /// segments under a chamfer one triangle wide, P4 4.0e-2 -> 2.1e-2 (P2 9.3e-2 -> 5.0e-2, P6
  /// 3.2e-2 -> 1.7e-2). A loft's elliptic rim (radius of curvature 0.125 at its tips, h = 0.1)
  /// turns 43 degrees at the tip's two vertices and 25 next to them: with the rule before
  /// (neighbours alike within 1.5x, at most 40 degrees) its tip edge stayed straight, P4 1.39e-3
  /// -> 2.1e-4.
  double coarse_circle_max_deg = 61.0;
  bool entity_borders = true;      ///< edges between faces of different input entities are features
  /// With entity_borders and several input entities (CAD faces, which are smooth inside), edges
  /// inside one entity are sharp only above angle_deg: the kink test is not run on them. Its
  /// stencils stop at the entity borders, and across a fillet strip three triangles wide (four
  /// rows of vertices on a 90 degree arc) the quadric and |y| interpolate: a Gmsh filleted box
  /// at h = 0.1 had 40 such kinks, its P4 1.4e-2 off.
  bool kinks_inside_entities = false;
  /// Tangent junctions (tangent_junctions.hpp): edges below angle_deg whose curvature_jump fit
  /// leaves at most junction_max_ratio of the plain quadric fit's residual, with a jump (x edge
  /// length) in [junction_min_jump, junction_max_jump], are features where at least
  /// junction_min_edges of them connect; from such a curve's free ends, edges passing
  /// junction_weak_ratio that continue it straight on (the end edges' stencils reach the next
  /// junction); then curves still ending in the open are dropped (a junction bounds a face: a
  /// partial find lets the fits reach round its ends, worse than none). The upper bound keeps
  /// the curved side's radius at 1.67 edges or more (a 90 degree fillet at least 2.6 edges
  /// across): narrower strips fit no better between junctions than across them (filleted box
  /// r = 0.15, h = 0.1, given as CAD faces: 2.75e-3, across 2.64e-3). It was 0.4 while one-sided
  /// fits of 90 degree strips were poor; with their torus fits (FitOptions::one_sided_torus) a
  /// cylinder's r = 0.12 rim fillets at h = 0.05 (jump about 0.5) went 6.1e-4 -> 2.2e-5, as
  /// given as CAD faces. Set on a Gmsh filleted box (h = 0.05: exactly its 360 CAD face borders;
  /// P4 6.9e-4 -> 3.1e-5); none on the analytic and CAD benchmark meshes.
  /// Last, a curved face whose every vertex is within junction_min_width edge hops of its border
  /// loses its junctions with other curved faces: too narrow for fits of its own, it fits better
  /// across them (filleted box r = 0.25, h = 0.05, vertical fillets two edges tall: P4 9.0e-4
  /// with them, 4.9e-4 without, 4.7e-4 with no junction at all; a width of 2 took r = 0.15's
  /// 3.1e-5 back to 6.9e-4).
  bool tangent_junctions = true;
  double junction_min_jump = 0.05;
  double junction_max_jump = 0.6;
  double junction_max_ratio = 0.3;
  double junction_weak_ratio = 0.7;
  /// 2, not 3: a fillet's border four edges long (filleted box r = 0.2, h = 0.05) has only two
  /// middle edges passing (its end edges' stencils reach the corner spheres): P4 3.3e-4 -> 3.8e-8.
  int junction_min_edges = 2;
  int junction_min_width = 1;
  /// Open curves made only of sharp edges, with a free end (feature valence 1) and fewer than
  /// this many edges, are dropped as noise; 0 keeps every curve. Why: a crease one or two edges
  /// long that ends in the open is where a coarse or needle-ridden mesh of a smooth surface turns
  /// by more than angle_deg, or a scan's noise; its one-sided fits bent the elements around it.
  /// P4 max distance to the exact surface: a Gmsh ellipsoid of 226 triangles 1.8e-2 -> 3.1e-4 (its
  /// tips), marching-tetrahedra tori grid 16 / 24 1.9e-2 / 7.5e-4 -> 8.5e-5 / 1.8e-5, capsule and
  /// filleted box at h = 0.3 / 0.2 2.5x and 3x closer; CAD solids and the CAD exports unchanged.
  /// Scans' P4 deviation from the input: bunny_closed 0.50 -> 0.38%, hammer 0.10 -> 0.064%,
  /// armadillo 0.30 -> 0.28%, skull 0.44 -> 0.46%; P6 stanford_bunny_scan 0.21 -> 0.28%. 5
  /// instead of 3 also freed coarse tori (h = r / 1.6: 2.3e-2 -> 8.2e-4) but took bunny_closed to
  /// 0.75% and a half torus beyond its linear error.
  int min_dangling_edges = 3;
  /// A crease of sharp edges, at least 2 x min_dangling_edges long, that ends one edge short of
  /// another curve (a vertex with two feature edges or more) is continued through that edge when
  /// it turns by at least weak_angle_deg and crease_gap_ratio x the crease's last edge, leaving the
  /// crease by at most corner_angle_deg (the edge nearest straight on); 0 turns it off. Why: a rim
  /// where a sphere meets a plane at 33.6 degrees (a Gmsh block with a spherical cap, h = 0.1) was
  /// found by the kink test but for its edge at the block's corner, whose stencils the corner's
  /// three planes spoil; the fits crossed the gap, and that rim edge stayed a chord of the plane
  /// (P4 5.1e-4, Gmsh's exact-CAD P4 2.2e-6). Scans' creases are mostly short fragments: with
  /// creases of any length ending near any feature vertex, 28 gaps on boot (max deviation from the
  /// input 0.306 -> 0.324%); as set, 3 (unchanged). A shorter crease (min_dangling_edges or more)
  /// is continued only where it ends one edge short of other curves at both ends: a coarse nut's
  /// 30-degree chamfer rim between two cusps (h = 0.25: P4 8.2e-3 -> 2.8e-5); boot unchanged.
  double crease_gap_ratio = 0.7;
  /// Sharp edges (above angle_deg, or by the kink test) among vertices on one exact quadric are
  /// chords of a coarse smooth CAD face, not creases (edge_on_exact_quadric).
  bool exact_quadrics = true;
  ExactQuadricOptions quadric;
  /// Mark cone points (cone_points.hpp): the fits treat them as walls, like feature curves.
  bool cone_points = true;
  /// Sharp edges joined to a vertex that is a cone point when the features are ignored, all
  /// within this many rings of it, are a coarse apex's fan, not feature curves (features.cpp,
  /// step 5). 4: Gmsh's cone (r = 0.5, height 1) at h = 0.05 has sharp edges 3 rings out, at
  /// h = 0.3 (258 triangles) and a double cone at h = 0.08 4 rings out (P4 4.9e-2 / 2.0e-2, the
  /// linear error, with 3 rings; 3.0e-3 / 1.7e-3 with 4).
  int apex_rings = 4;
  /// ... and those rings must fit a cone model (fit_cone_model) within this x h, RMS.
  double apex_max_residual = 0.01;
  ConeOptions cone;
};

struct Features {
  std::vector<char> edge_feature;     ///< per Topology edge: 1 if a feature edge
  std::vector<char> vertex_feature;   ///< per vertex: 1 if on a feature edge
  std::vector<char> vertex_corner;    ///< per vertex: 1 if a corner (curves meet, end or turn sharply): stays put
  /// Per vertex: 1 if a cone point (the apex of a cone, off the curves): stays put, and no fit
  /// reaches across it (a smooth fit rounds the apex off: P4 up to 7x further from a cone than
  /// its linear input).
  std::vector<char> vertex_cone;
  /// Feature curves as vertex chains between corners (or closed loops: front()==back()).
  std::vector<std::vector<int>> curves;
  std::vector<int> edge_curve;        ///< per edge: curve index, -1 if not a feature
  long long sharp_edges = 0, boundary_edges = 0, nonmanifold_edges = 0, entity_border_edges = 0;
  int corners = 0;
  int cone_points = 0;
  long long feature_edges = 0;        ///< edges with edge_feature == 1 (an edge may be of several kinds above)
  int closed_curves = 0;              ///< curves that are closed loops without corners
  long long pruned_edges = 0;         ///< sharp edges dropped by min_dangling_edges (still counted in sharp_edges)
  long long apex_edges = 0;           ///< sharp edges dropped round coarse cone apexes (still counted in sharp_edges)
  long long quadric_edges = 0;        ///< edges above angle_deg or kinked but on an exact quadric: not sharp
  long long kink_edges = 0;           ///< sharp edges accepted by the kink test (below angle_deg, or of a cap)
  long long gap_edges = 0;            ///< sharp edges closing a one-edge gap in a crease (crease_gap_ratio)
  long long junction_edges = 0;       ///< tangent junction edges (FeatureOptions::tangent_junctions)
};

/// Detects feature edges, chains them into curves and marks corners.
/// An interior edge (two faces) is sharp when the angle between its two face normals, as
/// oriented in the input, exceeds opt.angle_deg (35° by default: a 90° CAD rim is caught, a
/// sphere discretised with >= 10 segments around is not; edges of caps: cap_angle_deg).
/// Boundary and non-manifold edges are always features; entity borders when
/// opt.entity_borders. Faces of zero area have no normal and never make an edge sharp. Curves
/// and corners are numbered deterministically (by vertex and edge index).
Features detect_features(const Mesh& mesh, const Topology& T, const FeatureOptions& opt = {});

}  // namespace hocurve
