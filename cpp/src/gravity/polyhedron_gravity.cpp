#include "tubempc/gravity/polyhedron_gravity.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

namespace tubempc::gravity {

namespace {

using Index = Eigen::Index;
using A4 = Eigen::Array4d;
using CMap4 = Eigen::Map<const A4>;

// Cluster capacities: per-point buffers live on the stack. Edge and face counts are padded to
// multiples of 4 (padding has zero dyads, so it contributes nothing).
constexpr int kMaxClusterVertices = 128;
constexpr int kMaxClusterFaces = 256;
constexpr int kMaxClusterEdges = 3 * kMaxClusterFaces;

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kPi = 3.14159265358979323846;

int padded(int n) { return (n + 3) & ~3; }

// atan2(y, x) for n values, Cephes' rational approximation of atan on [0, 1] (<= 1 ulp) with
// octant reduction; branch-free so that the loop vectorises. atan2(+-0, x) = +-0 for x >= 0.
void atan2_block(const double* y, const double* x, double* out, int n) {
  constexpr double P0 = -8.750608600031904122785e-1, P1 = -1.615753718733365076637e1,
                   P2 = -7.500855792314704667340e1, P3 = -1.228866684490136173410e2,
                   P4 = -6.485021904942025371773e1;
  constexpr double Q0 = 2.485846490142306297962e1, Q1 = 1.650270098316988542046e2,
                   Q2 = 4.328810604912902668951e2, Q3 = 4.853903996359136964868e2,
                   Q4 = 1.945506571482613964425e2;
  constexpr double kMoreBits = 6.123233995736765886130e-17;  // pi/2 - fl(pi/2)
  for (int k = 0; k < n; ++k) {
    const double ax = std::fabs(x[k]), ay = std::fabs(y[k]);
    const double hi = ax > ay ? ax : ay;
    const double lo = ax > ay ? ay : ax;
    const double t = lo / (hi > 0.0 ? hi : 1.0);  // in [0, 1]
    const bool big = t > 0.66;
    const double t_big = (t - 1.0) / (t + 1.0);  // both branches computed: no control flow
    const double u = big ? t_big : t;
    const double z = u * u;
    const double p = (((P0 * z + P1) * z + P2) * z + P3) * z + P4;
    const double q = ((((z + Q0) * z + Q1) * z + Q2) * z + Q3) * z + Q4;
    double r = u * (z * p / q) + u;
    r = big ? (0.25 * kPi) + (r + 0.5 * kMoreBits) : r;
    r = ay > ax ? (0.5 * kPi - r) + kMoreBits : r;
    r = x[k] < 0.0 ? (kPi - r) + 2.0 * kMoreBits : r;
    out[k] = std::copysign(r, y[k]);
  }
}

}  // namespace

struct PolyhedronGravity::Sums {
  double u_edge{0.0}, u_face{0.0};
  Eigen::Vector3d a_edge{Eigen::Vector3d::Zero()}, a_face{Eigen::Vector3d::Zero()};
  std::array<double, 6> h_edge{}, h_face{};  // xx, xy, xz, yy, yz, zz
  double w_sum{0.0};
};

PolyhedronGravity::PolyhedronGravity(Shape shape, double density)
    : shape_(std::move(shape)), density_(density), g_rho_(kGravitationalConstant * density) {
  if (!std::isfinite(density) || density <= 0.0) {
    throw std::invalid_argument("PolyhedronGravity: density must be finite and > 0 (kg/m^3), got " +
                                std::to_string(density));
  }
  center_ = shape_.center_of_mass();
  const Vertices& V = shape_.vertices();
  const Faces& F = shape_.faces();
  const Index nv = V.rows(), nf = F.rows();
  const Vertices vc = V.rowwise() - center_.transpose();
  r_max_ = vc.rowwise().norm().maxCoeff();
  r_far_ = kFarFieldFactor * r_max_;
  const Eigen::Matrix3d inertia = shape_.inertia(density_);
  quadrupole_ = kGravitationalConstant * (inertia.trace() * Eigen::Matrix3d::Identity() - 3.0 * inertia);

  // Face adjacency (three neighbours per face on a closed manifold).
  std::vector<std::array<Index, 3>> adjacent(static_cast<size_t>(nf));
  std::vector<int> n_adj(static_cast<size_t>(nf), 0);
  for (const MeshEdge& e : shape_.edges()) {
    adjacent[static_cast<size_t>(e.face_a)][static_cast<size_t>(n_adj[static_cast<size_t>(e.face_a)]++)] =
        e.face_b;
    adjacent[static_cast<size_t>(e.face_b)][static_cast<size_t>(n_adj[static_cast<size_t>(e.face_b)]++)] =
        e.face_a;
  }

  // Clusters grown breadth-first over unassigned faces while vertices and faces fit.
  std::vector<std::int32_t> cluster_of(static_cast<size_t>(nf), -1);
  std::vector<std::array<std::uint16_t, 3>> local_of_face(static_cast<size_t>(nf));
  std::vector<std::int32_t> local_of_vertex(static_cast<size_t>(nv), -1);
  std::vector<std::vector<Index>> cluster_faces;
  std::vector<std::vector<Index>> cluster_vertices;
  std::vector<Index> queue;
  for (Index seed = 0; seed < nf; ++seed) {
    if (cluster_of[static_cast<size_t>(seed)] >= 0) continue;
    const auto c = static_cast<std::int32_t>(cluster_faces.size());
    cluster_faces.emplace_back();
    cluster_vertices.emplace_back();
    std::vector<Index>& cf = cluster_faces.back();
    std::vector<Index>& cv = cluster_vertices.back();
    queue.assign(1, seed);
    for (size_t q = 0; q < queue.size() && static_cast<int>(cf.size()) < kMaxClusterFaces; ++q) {
      const Index f = queue[q];
      if (cluster_of[static_cast<size_t>(f)] >= 0) continue;
      int n_new = 0;
      for (int k = 0; k < 3; ++k) n_new += local_of_vertex[static_cast<size_t>(F(f, k))] < 0 ? 1 : 0;
      if (static_cast<int>(cv.size()) + n_new > kMaxClusterVertices) continue;
      cluster_of[static_cast<size_t>(f)] = c;
      cf.push_back(f);
      for (int k = 0; k < 3; ++k) {
        std::int32_t& l = local_of_vertex[static_cast<size_t>(F(f, k))];
        if (l < 0) {
          l = static_cast<std::int32_t>(cv.size());
          cv.push_back(F(f, k));
        }
        local_of_face[static_cast<size_t>(f)][static_cast<size_t>(k)] = static_cast<std::uint16_t>(l);
      }
      for (Index g : adjacent[static_cast<size_t>(f)]) {
        if (cluster_of[static_cast<size_t>(g)] < 0) queue.push_back(g);
      }
    }
    for (Index v : cv) local_of_vertex[static_cast<size_t>(v)] = -1;
  }
  const size_t nc = cluster_faces.size();

  // Edges bucketed by the cluster of face_a (both ends are vertices of that face).
  std::vector<std::vector<size_t>> cluster_edges(nc);
  for (size_t i = 0; i < shape_.edges().size(); ++i) {
    cluster_edges[static_cast<size_t>(cluster_of[static_cast<size_t>(shape_.edges()[i].face_a)])].push_back(
        i);
  }

  // Face geometry (unit normals), needed by the edge dyads.
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> normal(nf, 3);
  for (Index f = 0; f < nf; ++f) {
    const Eigen::Vector3d a = vc.row(F(f, 0)).transpose();
    const Eigen::Vector3d n = (vc.row(F(f, 1)).transpose() - a).cross(vc.row(F(f, 2)).transpose() - a);
    normal.row(f) = n.normalized().transpose();
  }

  clusters_.reserve(nc);
  for (size_t c = 0; c < nc; ++c) {
    Cluster cl{};
    cl.v_begin = static_cast<std::int32_t>(vx_.size());
    cl.v_count = static_cast<std::int32_t>(cluster_vertices[c].size());
    for (Index v : cluster_vertices[c]) {
      vx_.push_back(vc(v, 0));
      vy_.push_back(vc(v, 1));
      vz_.push_back(vc(v, 2));
    }

    cl.f_begin = static_cast<std::int32_t>(f_nx_.size());
    cl.f_count = padded(static_cast<int>(cluster_faces[c].size()));
    for (int k = 0; k < cl.f_count; ++k) {
      if (k >= static_cast<int>(cluster_faces[c].size())) {
        for (auto* arr : {&f_nx_, &f_ny_, &f_nz_, &f_d_, &f_n2_, &f_l12_, &f_l23_, &f_l31_})
          arr->push_back(0.0);
        for (auto* arr : {&f_i_, &f_j_, &f_k_}) arr->push_back(0);
        continue;
      }
      const Index f = cluster_faces[c][static_cast<size_t>(k)];
      const Eigen::Vector3d p1 = vc.row(F(f, 0)).transpose();
      const Eigen::Vector3d p2 = vc.row(F(f, 1)).transpose();
      const Eigen::Vector3d p3 = vc.row(F(f, 2)).transpose();
      const Eigen::Vector3d n = normal.row(f).transpose();
      f_nx_.push_back(n.x());
      f_ny_.push_back(n.y());
      f_nz_.push_back(n.z());
      f_d_.push_back(n.dot(p1));
      f_n2_.push_back((p2 - p1).cross(p3 - p1).norm());
      f_l12_.push_back((p2 - p1).squaredNorm());
      f_l23_.push_back((p3 - p2).squaredNorm());
      f_l31_.push_back((p1 - p3).squaredNorm());
      f_i_.push_back(local_of_face[static_cast<size_t>(f)][0]);
      f_j_.push_back(local_of_face[static_cast<size_t>(f)][1]);
      f_k_.push_back(local_of_face[static_cast<size_t>(f)][2]);
    }

    cl.e_begin = static_cast<std::int32_t>(e_len_.size());
    cl.e_count = padded(static_cast<int>(cluster_edges[c].size()));
    for (int k = 0; k < cl.e_count; ++k) {
      if (k >= static_cast<int>(cluster_edges[c].size())) {
        e_len_.push_back(1.0);  // any positive length: the padding's dyads are zero
        for (auto* arr :
             {&e_xx_, &e_xy_, &e_xz_, &e_yy_, &e_yz_, &e_zz_, &e_evx_, &e_evy_, &e_evz_, &e_vev_}) {
          arr->push_back(0.0);
        }
        e_i_.push_back(0);
        e_j_.push_back(0);
        continue;
      }
      const MeshEdge& me = shape_.edges()[cluster_edges[c][static_cast<size_t>(k)]];
      const Eigen::Vector3d p0 = vc.row(me.v0).transpose();
      const Eigen::Vector3d p1 = vc.row(me.v1).transpose();
      const Eigen::Vector3d u = (p1 - p0).normalized();
      const Eigen::Vector3d na = normal.row(me.face_a).transpose();
      const Eigen::Vector3d nb = normal.row(me.face_b).transpose();
      // Edge normals in each face's plane, pointing out of the face: face_a runs v0 -> v1.
      const Eigen::Vector3d n12a = u.cross(na);
      const Eigen::Vector3d n21b = (-u).cross(nb);
      Eigen::Matrix3d E = na * n12a.transpose() + nb * n21b.transpose();
      E = 0.5 * (E + E.transpose()).eval();
      const Eigen::Vector3d ev = E * p0;
      e_len_.push_back((p1 - p0).norm());
      e_xx_.push_back(E(0, 0));
      e_xy_.push_back(E(0, 1));
      e_xz_.push_back(E(0, 2));
      e_yy_.push_back(E(1, 1));
      e_yz_.push_back(E(1, 2));
      e_zz_.push_back(E(2, 2));
      e_evx_.push_back(ev.x());
      e_evy_.push_back(ev.y());
      e_evz_.push_back(ev.z());
      e_vev_.push_back(p0.dot(ev));
      const auto& lf = local_of_face[static_cast<size_t>(me.face_a)];
      std::uint16_t li = 0, lj = 0;
      for (int q = 0; q < 3; ++q) {
        if (F(me.face_a, q) == me.v0) li = lf[static_cast<size_t>(q)];
        if (F(me.face_a, q) == me.v1) lj = lf[static_cast<size_t>(q)];
      }
      e_i_.push_back(li);
      e_j_.push_back(lj);
    }
    clusters_.push_back(cl);
  }
}

template <PolyhedronGravity::Terms kTerms>
void PolyhedronGravity::accumulate(const Eigen::Vector3d& p, double tol_plane, Sums& s) const {
  constexpr bool kEdges = kTerms != Terms::Laplacian;
  constexpr bool kHessian = kTerms == Terms::All;
  alignas(64) double rn[kMaxClusterVertices];
  alignas(64) double num[kMaxClusterFaces];
  alignas(64) double den[kMaxClusterFaces];
  alignas(64) double w[kMaxClusterFaces];
  const double px = p.x(), py = p.y(), pz = p.z();
  A4 u_e = A4::Zero(), u_f = A4::Zero(), w_acc = A4::Zero();
  A4 ax_e = A4::Zero(), ay_e = A4::Zero(), az_e = A4::Zero();
  A4 ax_f = A4::Zero(), ay_f = A4::Zero(), az_f = A4::Zero();
  A4 hxx_e = A4::Zero(), hxy_e = A4::Zero(), hxz_e = A4::Zero(), hyy_e = A4::Zero(), hyz_e = A4::Zero(),
     hzz_e = A4::Zero();
  A4 hxx_f = A4::Zero(), hxy_f = A4::Zero(), hxz_f = A4::Zero(), hyy_f = A4::Zero(), hyz_f = A4::Zero(),
     hzz_f = A4::Zero();

  for (const Cluster& cl : clusters_) {
    // Distances from the point to the cluster's vertices.
    const double* vx = vx_.data() + cl.v_begin;
    const double* vy = vy_.data() + cl.v_begin;
    const double* vz = vz_.data() + cl.v_begin;
    for (int k = 0; k < cl.v_count; ++k) {
      const double dx = vx[k] - px, dy = vy[k] - py, dz = vz[k] - pz;
      rn[k] = std::sqrt(dx * dx + dy * dy + dz * dz);
    }

    // Faces: h = n.(v1 - p), numerator |N| h, denominator by the law of cosines
    // (2 r_i.r_j = r_i^2 + r_j^2 - l_ij^2).
    const int fb = cl.f_begin;
    for (int k = 0; k < cl.f_count; ++k) {
      const double r1 = rn[f_i_[fb + k]], r2 = rn[f_j_[fb + k]], r3 = rn[f_k_[fb + k]];
      const double h = f_d_[fb + k] - (f_nx_[fb + k] * px + f_ny_[fb + k] * py + f_nz_[fb + k] * pz);
      const double s1 = r1 * r1, s2 = r2 * r2, s3 = r3 * r3;
      num[k] = std::fabs(h) <= tol_plane ? 0.0 : f_n2_[fb + k] * h;
      den[k] = r1 * r2 * r3 + 0.5 * (r1 * (s2 + s3 - f_l23_[fb + k]) + r2 * (s3 + s1 - f_l31_[fb + k]) +
                                     r3 * (s1 + s2 - f_l12_[fb + k]));
      // In-plane faces get w = 0 whatever the sign of the denominator.
      den[k] = num[k] == 0.0 ? 1.0 : den[k];
    }
    atan2_block(num, den, w, cl.f_count);
    for (int k = 0; k < cl.f_count; k += 4) {
      const A4 wk = 2.0 * Eigen::Map<const A4>(w + k);
      const A4 nx = CMap4(f_nx_.data() + fb + k), ny = CMap4(f_ny_.data() + fb + k),
               nz = CMap4(f_nz_.data() + fb + k);
      const A4 h = CMap4(f_d_.data() + fb + k) - (nx * px + ny * py + nz * pz);
      w_acc += wk;
      const A4 hw = h * wk;
      u_f += h * hw;
      ax_f += nx * hw;
      ay_f += ny * hw;
      az_f += nz * hw;
      if constexpr (kHessian) {
        const A4 nxw = nx * wk, nyw = ny * wk;
        hxx_f += nx * nxw;
        hxy_f += ny * nxw;
        hxz_f += nz * nxw;
        hyy_f += ny * nyw;
        hyz_f += nz * nyw;
        hzz_f += nz * nz * wk;
      }
    }
    if constexpr (!kEdges) continue;

    // Edges: L = ln((a+b+e)/max(a+b-e, eps (a+b+e))), E r = E v_i - E p, r^T E r = v^T E v - p.(E v + E r).
    const int eb = cl.e_begin;
    for (int k = 0; k < cl.e_count; k += 4) {
      A4 ab;  // a + b
      for (int q = 0; q < 4; ++q) ab[q] = rn[e_i_[eb + k + q]] + rn[e_j_[eb + k + q]];
      const A4 len = CMap4(e_len_.data() + eb + k);
      // L = log1p(x), x = 2e/(a+b-e), as log(u) - c/u with u = fl(1+x) and c = (u-1) - x its exact
      // rounding error (u <= 2), so that L keeps full relative accuracy far away (x ~ e/|r| small);
      // c/u is taken as c (1-x) (error <= c x^2) and dropped for x >= 1 (error <= eps/2 against L > 0.69).
      const A4 x = 2.0 * len / (ab - len).max(kEps * (ab + len));
      const A4 u = 1.0 + x;
      const A4 c = (u - 1.0) - x;
      const A4 L = u.log() - c * (1.0 - x).max(0.0);
      const A4 exx = CMap4(e_xx_.data() + eb + k), exy = CMap4(e_xy_.data() + eb + k),
               exz = CMap4(e_xz_.data() + eb + k), eyy = CMap4(e_yy_.data() + eb + k),
               eyz = CMap4(e_yz_.data() + eb + k), ezz = CMap4(e_zz_.data() + eb + k);
      const A4 evx = CMap4(e_evx_.data() + eb + k), evy = CMap4(e_evy_.data() + eb + k),
               evz = CMap4(e_evz_.data() + eb + k);
      const A4 erx = evx - (exx * px + exy * py + exz * pz);
      const A4 ery = evy - (exy * px + eyy * py + eyz * pz);
      const A4 erz = evz - (exz * px + eyz * py + ezz * pz);
      const A4 rer = CMap4(e_vev_.data() + eb + k) - ((evx + erx) * px + (evy + ery) * py + (evz + erz) * pz);
      u_e += rer * L;
      ax_e += erx * L;
      ay_e += ery * L;
      az_e += erz * L;
      if constexpr (kHessian) {
        hxx_e += exx * L;
        hxy_e += exy * L;
        hxz_e += exz * L;
        hyy_e += eyy * L;
        hyz_e += eyz * L;
        hzz_e += ezz * L;
      }
    }
  }
  s.u_edge = u_e.sum();
  s.u_face = u_f.sum();
  s.w_sum = w_acc.sum();
  s.a_edge = {ax_e.sum(), ay_e.sum(), az_e.sum()};
  s.a_face = {ax_f.sum(), ay_f.sum(), az_f.sum()};
  s.h_edge = {hxx_e.sum(), hxy_e.sum(), hxz_e.sum(), hyy_e.sum(), hyz_e.sum(), hzz_e.sum()};
  s.h_face = {hxx_f.sum(), hxy_f.sum(), hxz_f.sum(), hyy_f.sum(), hyz_f.sum(), hzz_f.sum()};
}

namespace {

bool valid_point(const Eigen::Vector3d& r_A) { return r_A.allFinite() && r_A.cwiseAbs().maxCoeff() < 1e150; }

// r_A - c and its norm; throws for non-finite or absurdly distant points.
double checked_offset(const Eigen::Vector3d& r_A, const Eigen::Vector3d& center, Eigen::Vector3d& p) {
  if (!valid_point(r_A)) {
    throw std::domain_error("PolyhedronGravity: position must be finite with |r| < 1e150 m");
  }
  p = r_A - center;
  return p.norm();
}

}  // namespace

void PolyhedronGravity::far_field(const Eigen::Vector3d& p, double r, GravitySample& out) const {
  // U = GM/r + u^T Q u / (2 r^3), Q = G (tr I - 3 I), u = p/r; derivatives in terms of u.
  const double mu = gm();
  const Eigen::Vector3d u = p / r;
  const Eigen::Vector3d qu = quadrupole_ * u;
  const double s = u.dot(qu);
  const double r2 = r * r, r3 = r2 * r;
  out.potential = mu / r + 0.5 * s / r3;
  out.acceleration = -mu / r2 * u + (qu - 2.5 * s * u) / (r3 * r);
  const Eigen::Matrix3d uu = u * u.transpose();
  out.gradient = mu / r3 * (3.0 * uu - Eigen::Matrix3d::Identity()) +
                 (quadrupole_ - 5.0 * (qu * u.transpose() + u * qu.transpose()) -
                  2.5 * s * Eigen::Matrix3d::Identity() + 17.5 * s * uu) /
                     (r3 * r2);
}

void PolyhedronGravity::evaluate(const Eigen::Vector3d& r_A, GravitySample& out) const {
  Eigen::Vector3d p;
  const double r = checked_offset(r_A, center_, p);
  if (r > r_far_) {
    far_field(p, r, out);
    return;
  }
  Sums s;
  accumulate<Terms::All>(p, 16.0 * kEps * (r + r_max_), s);
  out.potential = 0.5 * g_rho_ * (s.u_edge - s.u_face);
  out.acceleration = -g_rho_ * (s.a_edge - s.a_face);
  const std::array<double, 6> h{s.h_edge[0] - s.h_face[0], s.h_edge[1] - s.h_face[1],
                                s.h_edge[2] - s.h_face[2], s.h_edge[3] - s.h_face[3],
                                s.h_edge[4] - s.h_face[4], s.h_edge[5] - s.h_face[5]};
  out.gradient << h[0], h[1], h[2], h[1], h[3], h[4], h[2], h[4], h[5];
  out.gradient *= g_rho_;
}

Eigen::Vector3d PolyhedronGravity::acceleration(const Eigen::Vector3d& r_A) const {
  Eigen::Vector3d p;
  const double r = checked_offset(r_A, center_, p);
  if (r > r_far_) {
    GravitySample g;
    far_field(p, r, g);
    return g.acceleration;
  }
  Sums s;
  accumulate<Terms::Acceleration>(p, 16.0 * kEps * (r + r_max_), s);
  return -g_rho_ * (s.a_edge - s.a_face);
}

double PolyhedronGravity::laplacian(const Eigen::Vector3d& r_A) const {
  Eigen::Vector3d p;
  const double r = checked_offset(r_A, center_, p);
  if (r > r_far_) return 0.0;  // far outside the body
  Sums s;
  accumulate<Terms::Laplacian>(p, 16.0 * kEps * (r + r_max_), s);
  return -g_rho_ * s.w_sum;
}

namespace {

// Runs body(i) for i in [0, n) on `threads` threads over contiguous chunks.
template <class Body>
void parallel_for(Index n, int threads, const Body& body) {
  if (threads < 0) throw std::invalid_argument("PolyhedronGravity: threads must be >= 0");
  unsigned t =
      threads == 0 ? std::max(1u, std::thread::hardware_concurrency()) : static_cast<unsigned>(threads);
  t = static_cast<unsigned>(std::min<Index>(static_cast<Index>(t), std::max<Index>(n, 1)));
  if (t <= 1) {
    for (Index i = 0; i < n; ++i) body(i);
    return;
  }
  std::vector<std::thread> pool;
  pool.reserve(t - 1);
  std::vector<std::exception_ptr> errors(t);
  auto run = [&](unsigned w) {
    try {
      const Index begin = n * w / t, end = n * (w + 1) / t;
      for (Index i = begin; i < end; ++i) body(i);
    } catch (...) {
      errors[w] = std::current_exception();
    }
  };
  for (unsigned w = 1; w < t; ++w) pool.emplace_back(run, w);
  run(0);
  for (auto& th : pool) th.join();
  for (auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
}

}  // namespace

void PolyhedronGravity::evaluate_batch(const Eigen::Ref<const Points>& r_A,
                                       Eigen::Ref<Eigen::VectorXd> potential, Eigen::Ref<Points> acceleration,
                                       Eigen::Ref<Gradients> gradient, int threads) const {
  const Index n = r_A.rows();
  if (potential.size() != n || acceleration.rows() != n || gradient.rows() != n) {
    throw std::invalid_argument("PolyhedronGravity::evaluate_batch: outputs must have " + std::to_string(n) +
                                " rows");
  }
  for (Index i = 0; i < n; ++i) {
    if (!valid_point(r_A.row(i).transpose())) {
      throw std::invalid_argument("PolyhedronGravity::evaluate_batch: point " + std::to_string(i) +
                                  " is not finite or has |r| >= 1e150 m");
    }
  }
  parallel_for(n, threads, [&](Index i) {
    GravitySample s;
    evaluate(r_A.row(i).transpose(), s);
    potential(i) = s.potential;
    acceleration.row(i) = s.acceleration.transpose();
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) gradient(i, 3 * a + b) = s.gradient(a, b);
    }
  });
}

void PolyhedronGravity::laplacian_batch(const Eigen::Ref<const Points>& r_A,
                                        Eigen::Ref<Eigen::VectorXd> laplacian_out, int threads) const {
  const Index n = r_A.rows();
  if (laplacian_out.size() != n) {
    throw std::invalid_argument("PolyhedronGravity::laplacian_batch: output must have " + std::to_string(n) +
                                " rows");
  }
  for (Index i = 0; i < n; ++i) {
    if (!valid_point(r_A.row(i).transpose())) {
      throw std::invalid_argument("PolyhedronGravity::laplacian_batch: point " + std::to_string(i) +
                                  " is not finite or has |r| >= 1e150 m");
    }
  }
  parallel_for(n, threads, [&](Index i) { laplacian_out(i) = laplacian(r_A.row(i).transpose()); });
}

}  // namespace tubempc::gravity
