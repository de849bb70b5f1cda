#include "meshmark/core/mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <numeric>

#include <fmt/format.h>

#include "meshmark/core/error.h"

namespace meshmark {

namespace {

[[noreturn]] void bad_index(std::string_view what, std::string_view face, long long f,
                            long long index, Eigen::Index nv) {
  throw InvalidArgumentError(fmt::format(
      "{}: {} {} has vertex index {} but the mesh has {} vertices", what, face, f, index, nv));
}

}  // namespace

void validate_mesh(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, std::string_view what) {
  for (Eigen::Index i = 0; i < V.rows(); ++i)
    if (!V.row(i).allFinite())
      throw InvalidArgumentError(
          fmt::format("{}: vertex {} has a non-finite coordinate ({}, {}, {})", what, i, V(i, 0),
                      V(i, 1), V(i, 2)));
  const Eigen::Index nv = V.rows();
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (F(f, c) < 0 || F(f, c) >= nv) bad_index(what, "face", f, F(f, c), nv);
}

void validate_mesh(const Mesh& mesh, std::string_view what) {
  validate_mesh(mesh.V, mesh.F, what);
  const Polygons& p = mesh.faces;
  const auto total = static_cast<std::int64_t>(p.indices.size());
  if (!p.offsets.empty() && (p.offsets.front() != 0 || p.offsets.back() != total ||
                             !std::is_sorted(p.offsets.begin(), p.offsets.end())))
    throw InvalidArgumentError(fmt::format(
        "{}: the polygons' offsets do not run from 0 to their {} indices in order", what, total));
  const Eigen::Index nv = mesh.V.rows();
  for (std::size_t k = 0; k + 1 < p.offsets.size(); ++k)
    for (std::int64_t q = p.offsets[k]; q < p.offsets[k + 1]; ++q)
      if (p.indices[q] < 0 || p.indices[q] >= nv)
        bad_index(what, "polygon", static_cast<long long>(k), p.indices[q], nv);
}

void Polygons::push_back(const int* first, std::size_t count) {
  indices.insert(indices.end(), first, first + count);
  offsets.push_back(static_cast<std::int64_t>(indices.size()));
}

Eigen::MatrixX3i triangulate(const Polygons& faces) {
  Eigen::Index count = 0;
  for (std::size_t k = 0; k < faces.size(); ++k) {
    const auto n = faces.offsets[k + 1] - faces.offsets[k];
    if (n >= 3) count += n - 2;
  }
  Eigen::MatrixX3i F(count, 3);
  Eigen::Index row = 0;
  for (std::size_t k = 0; k < faces.size(); ++k) {
    const int* f = faces.indices.data() + faces.offsets[k];
    const auto n = faces.offsets[k + 1] - faces.offsets[k];
    for (std::int64_t i = 1; i + 1 < n; ++i) F.row(row++) << f[0], f[i], f[i + 1];
  }
  return F;
}

Polygons polygons_from_triangles(const Eigen::MatrixX3i& F) {
  Polygons faces;
  faces.offsets.resize(static_cast<std::size_t>(F.rows()) + 1);
  faces.indices.resize(static_cast<std::size_t>(F.rows()) * 3);
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    faces.offsets[t + 1] = 3 * (t + 1);
    for (int c = 0; c < 3; ++c) faces.indices[3 * t + c] = F(t, c);
  }
  return faces;
}

void set_faces(Mesh& mesh, Polygons faces) {
  const std::size_t n = faces.size();
  bool triangles = true;
  for (std::size_t k = 0; k < n && triangles; ++k)
    triangles = faces.offsets[k + 1] - faces.offsets[k] == 3;
  if (!triangles) {
    mesh.F = triangulate(faces);
    mesh.faces = std::move(faces);
    return;
  }
  // Every face a triangle: F's rows are the faces. The offsets go first, so that the largest
  // moment of a read holds the corners and F, not the offsets too.
  std::vector<std::int64_t>().swap(faces.offsets);
  mesh.F.resize(static_cast<Eigen::Index>(n), 3);
  for (std::size_t t = 0; t < n; ++t)
    for (int c = 0; c < 3; ++c)
      mesh.F(static_cast<Eigen::Index>(t), c) = faces.indices[3 * t + static_cast<std::size_t>(c)];
  mesh.faces = Polygons{};
}

Polygons file_faces(const Mesh& mesh) {
  if (mesh.faces.size() > 0) return mesh.faces;
  return polygons_from_triangles(mesh.F);
}

Mesh make_mesh(Eigen::MatrixX3d V, Eigen::MatrixX3i F) {
  Mesh mesh;
  mesh.V = std::move(V);
  mesh.F = std::move(F);
  return mesh;
}

std::vector<std::uint8_t> referenced_vertices(const Eigen::MatrixX3i& F, Eigen::Index nv) {
  std::vector<std::uint8_t> used(static_cast<std::size_t>(nv), 0);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) used[static_cast<std::size_t>(F(t, c))] = 1;
  return used;
}

double bounding_box_diagonal(const Eigen::MatrixX3d& V, const std::vector<std::uint8_t>& mask) {
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::RowVector3d hi = -lo;
  bool any = false;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    if (!mask.empty() && !mask[static_cast<std::size_t>(i)]) continue;
    lo = lo.cwiseMin(V.row(i));
    hi = hi.cwiseMax(V.row(i));
    any = true;
  }
  return any ? (hi - lo).norm() : 0.0;
}

Adjacency vertex_adjacency(const Eigen::MatrixX3i& F, Eigen::Index nv) {
  // Bucket the directed edges by their first vertex (two passes: count, fill), then sort and
  // deduplicate each vertex's short list: linear in the faces, no global sort.
  std::vector<int> start(static_cast<std::size_t>(nv) + 1, 0);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a == b) continue;
      ++start[a + 1];
      ++start[b + 1];
    }
  std::partial_sum(start.begin(), start.end(), start.begin());
  std::vector<int> slots(static_cast<std::size_t>(start[nv]));
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (Eigen::Index t = 0; t < F.rows(); ++t)
    for (int c = 0; c < 3; ++c) {
      const int a = F(t, c), b = F(t, (c + 1) % 3);
      if (a == b) continue;
      slots[fill[a]++] = b;
      slots[fill[b]++] = a;
    }
  Adjacency adj;
  adj.offsets.assign(static_cast<std::size_t>(nv) + 1, 0);
  adj.indices.reserve(slots.size() / 2);
  for (Eigen::Index i = 0; i < nv; ++i) {
    const auto first = slots.begin() + start[i], last = slots.begin() + start[i + 1];
    std::sort(first, last);
    adj.indices.insert(adj.indices.end(), first, std::unique(first, last));
    adj.offsets[i + 1] = static_cast<int>(adj.indices.size());
  }
  return adj;
}

Eigen::MatrixX3d face_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  Eigen::MatrixX3d N(F.rows(), 3);
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    const Eigen::RowVector3d n =
        (V.row(F(t, 1)) - V.row(F(t, 0))).cross(V.row(F(t, 2)) - V.row(F(t, 0)));
    const double len = n.norm();
    N.row(t) = len > 0 ? Eigen::RowVector3d(n / len) : Eigen::RowVector3d::Zero();
  }
  return N;
}

Eigen::MatrixX3d vertex_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  Eigen::MatrixX3d N = Eigen::MatrixX3d::Zero(V.rows(), 3);
  for (Eigen::Index t = 0; t < F.rows(); ++t) {
    const Eigen::RowVector3d n =
        (V.row(F(t, 1)) - V.row(F(t, 0))).cross(V.row(F(t, 2)) - V.row(F(t, 0)));
    for (int c = 0; c < 3; ++c) N.row(F(t, c)) += n;
  }
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const double len = N.row(i).norm();
    if (len > 0) N.row(i) /= len;
  }
  return N;
}

std::vector<int> first_at_same_position(const Eigen::MatrixX3d& V,
                                        const std::vector<std::uint8_t>& mask) {
  const auto nv = static_cast<int>(V.rows());
  // Open addressing on the positions' bits (-0.0 and +0.0 hash and compare equal): the first
  // index seen at a position, the smallest, leads its group. O(n), no sort.
  std::size_t slots = 16;
  while (slots < 2 * static_cast<std::size_t>(nv)) slots *= 2;
  std::vector<int> table(slots, -1);
  auto bits = [](double x) {
    std::uint64_t b;
    x += 0.0;  // -0.0 becomes +0.0
    std::memcpy(&b, &x, sizeof b);
    return b;
  };
  // The hashes first, in order, so that the table slot of a position some way ahead can be
  // prefetched: on large meshes the table does not fit the cache and every probe would miss.
  std::vector<std::uint64_t> hash(static_cast<std::size_t>(nv));
  for (int i = 0; i < nv; ++i) {
    std::uint64_t h = bits(V(i, 0)) * 0x9E3779B97F4A7C15ull;
    h = (h ^ (h >> 29) ^ bits(V(i, 1))) * 0xBF58476D1CE4E5B9ull;
    h = (h ^ (h >> 32) ^ bits(V(i, 2))) * 0x94D049BB133111EBull;
    hash[static_cast<std::size_t>(i)] = h ^ (h >> 31);
  }
  constexpr int kAhead = 16;
  std::vector<int> leader(static_cast<std::size_t>(nv), -1);
  for (int i = 0; i < nv; ++i) {
    if (i + kAhead < nv)
      __builtin_prefetch(&table[hash[static_cast<std::size_t>(i) + kAhead] & (slots - 1)]);
    if (!mask[static_cast<std::size_t>(i)]) continue;
    const std::uint64_t h = hash[static_cast<std::size_t>(i)];
    for (std::size_t k = h & (slots - 1);; k = (k + 1) & (slots - 1)) {
      const int j = table[k];
      if (j < 0) {
        table[k] = i;
        leader[static_cast<std::size_t>(i)] = i;
        break;
      }
      if (V(j, 0) == V(i, 0) && V(j, 1) == V(i, 1) && V(j, 2) == V(i, 2)) {
        leader[static_cast<std::size_t>(i)] = j;
        break;
      }
    }
  }
  return leader;
}

PositionGroups group_identical_positions(const Eigen::MatrixX3d& V,
                                         const std::vector<std::uint8_t>& referenced) {
  const auto nv = static_cast<int>(V.rows());
  const std::vector<int> leader = first_at_same_position(V, referenced);
  PositionGroups groups;
  groups.group_of.assign(static_cast<std::size_t>(nv), -1);
  std::vector<int> sizes;
  for (int i = 0; i < nv; ++i) {
    const int l = leader[static_cast<std::size_t>(i)];
    if (l < 0) continue;
    if (l == i) {
      groups.group_of[static_cast<std::size_t>(i)] = static_cast<int>(sizes.size());
      sizes.push_back(0);
    } else {
      groups.group_of[static_cast<std::size_t>(i)] = groups.group_of[static_cast<std::size_t>(l)];
    }
    ++sizes[static_cast<std::size_t>(groups.group_of[static_cast<std::size_t>(i)])];
  }
  groups.offsets.resize(sizes.size() + 1);
  std::partial_sum(sizes.begin(), sizes.end(), groups.offsets.begin() + 1);
  groups.members.resize(static_cast<std::size_t>(groups.offsets.back()));
  std::vector<int> fill(groups.offsets.begin(), groups.offsets.end() - 1);
  for (int i = 0; i < nv; ++i) {
    const int g = groups.group_of[static_cast<std::size_t>(i)];
    if (g >= 0) groups.members[static_cast<std::size_t>(fill[static_cast<std::size_t>(g)]++)] = i;
  }
  return groups;
}

}  // namespace meshmark
