// RAII Gmsh session for tests: initialise quietly, finalise at scope exit.
#pragma once
#include <gmsh.h>

struct GmshSession {
  GmshSession() {
    gmsh::initialize();
    gmsh::option::setNumber("General.Terminal", 0);
  }
  ~GmshSession() { gmsh::finalize(); }
};
