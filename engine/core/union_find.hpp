// Disjoint sets over 0..n-1 as a parent array (parent[i] == i: a root).
#pragma once
#include <vector>

namespace hocurve {

/// The root of a's set, halving the path on the way.
inline int find_root(std::vector<int>& parent, int a) {
  while (parent[a] != a) a = parent[a] = parent[parent[a]];
  return a;
}

}  // namespace hocurve
