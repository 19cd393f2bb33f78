// Particles stage, after the particle clouds of "Interactive Invigoration: Volumetric Modeling of
// Trees with Strands" (Li, Schwarz, Pałubicki, Pirk, Benes).
//
// The clouds are built bottom-up. What each node does, and why:
//
//  - Sizing. s is a density length: a tip of radius r gets max(min_particles, round((r/s)^2))
//    particles. Every node's cloud is simulated in units of its own length
//    lambda = r / sqrt(m) (m = its particle count), so all parameters are relative to the
//    cloud itself; a cloud that is rotated and scaled keeps being a relaxed cloud. That is what
//    makes chains of single-child nodes nearly free (see "Carry").
//
//  - Counts first. The number of particles of every node depends only on the radii and the
//    children's counts (new strands are added where r / sqrt(carried) > new_strand_sparsity
//    * s, up to the nominal count), so one O(#N) pass fixes every count, every node's range in
//    the flat arrays and every strand id before any geometry is computed. The parallel phase
//    then writes each node's range by index and never allocates per node.
//
//  - Tips: a sunflower (Vogel) spiral, evenly spread in the disc by construction, relaxed,
//    and rotated by a random angle from the node's own stream. Tips of up to 256 particles
//    take the relaxed pattern for their count from a per-thread cache (a pure function of the
//    count and the parameters, so every thread computes the same bits), scaled by lambda.
//
//  - Carry (one child): the child's 2D coordinates are taken into the parent's frame by the
//    minimal rotation between the two tangents (the frames are parallel-transported, so this is
//    the identity up to rounding) and scaled by the ratio of the confining disc radii, which
//    fits the cloud to the parent's radius. When no new strands start at the node and the
//    child's relaxation converged, the carried cloud is a similarity image of a converged cloud
//    and the (scale- and rotation-invariant) simulation would stop at once: it is skipped. This
//    is the hint of the issue ("exploit that ... for speed") made exact.
//
//  - Fork: each child's cloud is carried into the parent's plane as above
//    (the rotation part of the projection along the child's direction; the oblique stretch
//    that the literal projection adds would be undone by the fit below) and placed on its
//    child's side of the child-to-child direction D12: the disc is cut by a chord
//    perpendicular to D12 into two parts whose areas are proportional to the two particle
//    counts, with an optional empty band of fork_gap between them (the seed's "offset so that
//    the two clouds are adjacent"; the authors add a particle diameter, but a band is left as
//    a hole when the relaxation settles early, so the default is 0). Each child's disc is
//    mapped onto its part by an area-preserving star map (StarMap): polar coordinates about
//    the disc's centre and about the centre of the part's inscribed circle, directions matched
//    by area, radii scaled to the part's boundary. The map is continuous, keeps a uniform
//    cloud uniform and keeps its boundary on the boundary, so the side of the bundle that faced
//    the other child lines the cut and neighbours stay neighbours (no side swaps). The union
//    fills the parent disc evenly from the start, which a uniform scaling of two side-by-side
//    discs does not (it leaves two empty crescents that take long to fill by relaxation).
//    A first version mapped the coordinate along D12 by cumulative area and the other one
//    along the chord (Knothe-Rosenblatt); it squeezes a thin cap of the disc along the whole
//    cut, and 5-8% of the strands near the cut lost most of their neighbours (the star map:
//    about 1%).
//
//    Forks of at most 32 particles take the relaxed tip pattern of their count instead, the
//    mapped positions only choosing which slot each particle takes (snap_to_pattern): with so
//    few particles the mapped bundles sit on the boundaries of their halves, and the
//    relaxation can settle with holes in the middles.
//
//  - New strands: candidate positions are a sunflower spiral with the node's full count;
//    the candidates farthest from the carried particles take the new strands (they are the
//    holes of the sparse cloud), then the whole cloud is relaxed.
//
//  - Relaxation: particles repel with force kappa (h^2/d - d) for d < h
//    (kappa = 1/2h: zero at h with the slope of the classic (1 - d/h), but unbounded as d -> 0,
//    so close pairs always separate first; one division and no square root per pair), move
//    with momentum `damping` and a velocity cap (the seed found the cap essential for an even
//    density), in single precision and units of lambda. The boundary is a soft wall: a
//    particle near it is repelled by its mirror image across a circle wall_offset outside the
//    confining disc, and is clamped to the disc as a last resort. A hard wall alone (clamping)
//    lets the bounded pressure of the interior pile particles up on the rim; the mirror keeps
//    the density even up to an outer ring about half a lambda inside the radius.
//    Neighbours come from Verlet lists: a uniform grid with cells of half the list radius
//    (counting sort, any occupancy; the particles are re-sorted by cell so every row of cells
//    is a contiguous slot range), lists of the pairs within h + skin, rebuilt when twice the
//    summed largest moves since the last rebuild reach the skin (so no interacting pair is ever
//    missed) and at least every rebuild_every steps. Late steps skip particles at rest: one
//    that moved less than half the tolerance, with all its neighbours, keeps its place (the
//    settling region of a fork is usually small). The run stops when the largest move is below
//    move_tolerance or after max_steps. Clouds of 4096 particles or more run each step as a
//    parallel loop over particles; every particle sums over its own list in a fixed order and
//    the largest move is a maximum, so the split over threads does not change a bit.
//
//  - Parallelism: nodes are processed bottom-up with one atomic counter of unfinished
//    children per node; tips are distributed over threads (oneTBB) and a thread that finishes
//    the last child of a node continues with that node, so independent subtrees run in
//    parallel and chains run without scheduling overhead. Each node reads only its children's
//    finished clouds and its own random stream derive_seed(seed, node), and all arithmetic of
//    a node is sequential, so the output is bit-identical for any thread count.

#include "particles/particles.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/spin_mutex.h>
#include <tbb/task_arena.h>

#include "core/errors.h"
#include "core/rng.h"

namespace sm {
namespace {

constexpr double kPi = std::numbers::pi;
/// Golden angle (radians) of the sunflower spiral.
const double kGoldenAngle = kPi * (3.0 - std::sqrt(5.0));
/// Neighbour distance of a hexagonal packing with one particle per pi * lambda^2.
const double kHexDistance = std::sqrt(2.0 * kPi / std::sqrt(3.0));

// Per-node warning flags, turned into counted warnings in node order after the parallel phase.
enum NodeFlag : std::uint8_t {
  kThinTip = 1,
  kBackwardChild = 2,
  kForkDirectionDegenerate = 4,
  kForkChildrenCoincide = 8,
  kForkChildrenColinear = 16,
};

void validate_params(const ParticleParams& p) { check_params(p); }

// ---------------------------------------------------------------------------------------------
// Counts

/// max(min_particles, round((r / s)^2)), saturated far above any valid count.
std::uint64_t nominal_count(double r, double s, std::uint32_t min_particles) {
  const double q = (r / s) * (r / s);
  const double rounded = q < 1e15 ? std::floor(q + 0.5) : 1e15;
  return std::max<std::uint64_t>(min_particles, static_cast<std::uint64_t>(rounded));
}

/// Whether `carried` strands are too sparse for radius r: r / sqrt(carried) > sparsity * s.
bool too_sparse(double r, double s, std::uint64_t carried, double sparsity) {
  const double l = sparsity * s;
  return static_cast<double>(carried) * l * l < r * r;
}

/// Particle count and new strands of every node for spacing s (bottom-up, O(#N)).
/// Counts saturate at `cap` so absurd spacings cannot overflow.
struct Layout {
  std::vector<std::uint64_t> count;  // #N
  std::vector<std::uint64_t> fresh;  // #N strands starting at the node (all of a tip's)
  std::uint64_t total = 0;           // sum of count (saturated)
};

Layout count_layout(const Skeleton& sk, double s, const ParticleParams& p, std::uint64_t cap) {
  const std::size_t n = sk.size();
  Layout l;
  l.count.assign(n, 0);
  l.fresh.assign(n, 0);
  for (std::size_t i = n; i-- > 0;) {
    const auto& ch = sk.children[i];
    const double r = sk.radius[i];
    std::uint64_t carried = 0;
    for (NodeId c : ch) {
      if (c.valid()) carried += l.count[c.idx()];
    }
    std::uint64_t fresh = 0;
    if (carried == 0) {
      fresh = nominal_count(r, s, p.min_particles);
    } else if (too_sparse(r, s, carried, p.new_strand_sparsity)) {
      const std::uint64_t target = nominal_count(r, s, p.min_particles);
      fresh = target > carried ? target - carried : 0;
    }
    l.count[i] = std::min(cap, carried + fresh);
    l.fresh[i] = std::min(cap, fresh);
    l.total = std::min(cap, l.total + l.count[i]);
  }
  return l;
}

/// Root strand count for spacing s (same rule as count_layout, without storing per node
/// what is not needed).
std::uint64_t root_count(const Skeleton& sk, double s, const ParticleParams& p, std::vector<std::uint64_t>& count) {
  constexpr std::uint64_t cap = std::uint64_t(1) << 40;
  const std::size_t n = sk.size();
  count.assign(n, 0);
  for (std::size_t i = n; i-- > 0;) {
    std::uint64_t carried = 0;
    for (NodeId c : sk.children[i]) {
      if (c.valid()) carried += count[c.idx()];
    }
    const double r = sk.radius[i];
    std::uint64_t m = carried;
    if (carried == 0 || too_sparse(r, s, carried, p.new_strand_sparsity)) {
      m = std::max(carried, nominal_count(r, s, p.min_particles));
    }
    count[i] = std::min(cap, m);
  }
  return count[0];
}

// ---------------------------------------------------------------------------------------------
// Geometry helpers

/// 2x2 linear map (columns a, b): child 2D coordinates -> parent 2D coordinates, by the
/// minimal rotation taking the child's tangent to the parent's (a proper rotation).
struct Map2 {
  dvec2 a{1, 0}, b{0, 1};
  [[nodiscard]] dvec2 operator()(dvec2 p) const { return p.x * a + p.y * b; }
};

Map2 carry_map(const Frame& child, const Frame& parent) {
  const Frame g = transport_frame(child, parent.tangent);
  return Map2{parent.to_local(g.normal), parent.to_local(g.binormal)};
}

/// Area of the part {u > x} of the unit disc.
double segment_area(double x) {
  x = std::clamp(x, -1.0, 1.0);
  return std::acos(x) - x * std::sqrt(1.0 - x * x);
}

/// Area-preserving star map from the unit disc onto the segment {u >= xs} of the unit disc.
/// Both are seen in polar coordinates, the disc from its centre and the segment from the
/// centre of its inscribed circle ((1 + xs) / 2, 0): a direction theta of the disc goes to the
/// direction psi of the segment that splits the segment's area in the same proportion, and
/// the radius is scaled by the distance B(psi) to the segment's boundary. So the disc's
/// boundary goes onto the segment's boundary (about a quarter of it onto the cut: the side of
/// the bundle facing the other child lines the cut), uniform density stays uniform, and the
/// map is continuous with bounded distortion (unlike mapping the coordinate along D12 first,
/// which squeezes a thin cap of the disc along the whole cut).
class StarMap {
 public:
  StarMap(double xs, int steps) : xs_(std::clamp(xs, -1.0, 1.0)), steps_(std::clamp(steps, 16, kMaxSteps)) {
    c_ = 0.5 * (1.0 + xs_);
    // Cumulative area fraction T(psi) on psi_k = -pi + 2 pi k / steps (trapezoids of B^2 / 2).
    cum_[0] = 0;
    double prev = boundary(-1.0);
    prev *= prev;
    for (int k = 1; k <= steps_; ++k) {
      double b = boundary(std::cos(-kPi + 2.0 * kPi * k / steps_));
      b *= b;
      cum_[k] = cum_[k - 1] + 0.5 * (prev + b);
      prev = b;
    }
    for (int k = 1; k <= steps_; ++k) cum_[k] /= cum_[steps_];
  }

  /// Maps the point (a, b) of the unit disc (a along the segment's axis).
  [[nodiscard]] dvec2 operator()(double a, double b) const {
    const double rho = std::min(1.0, std::sqrt(a * a + b * b));
    const double frac = rho > 0 ? (std::atan2(b, a) + kPi) / (2.0 * kPi) : 0.5;
    const double* it = std::upper_bound(cum_, cum_ + steps_ + 1, frac);
    const int hi = std::clamp(int(it - cum_), 1, steps_);
    const double c0 = cum_[hi - 1], c1 = cum_[hi];
    const double t = c1 > c0 ? std::clamp((frac - c0) / (c1 - c0), 0.0, 1.0) : 0.0;
    const double psi = -kPi + 2.0 * kPi * (hi - 1 + t) / steps_;
    const double cs = std::cos(psi), sn = std::sin(psi);
    const double r = rho * boundary(cs);
    return {c_ + r * cs, r * sn};
  }

 private:
  /// Distance from the inscribed centre (c, 0) to the segment's boundary in the direction
  /// with cosine cs (the boundary is symmetric about the axis).
  [[nodiscard]] double boundary(double cs) const {
    const double disc = std::sqrt(std::max(0.0, c_ * c_ * cs * cs - c_ * c_ + 1.0));
    double t = -c_ * cs + disc;  // to the circle
    if (cs < 0) t = std::min(t, (xs_ - c_) / cs);  // to the cut
    return std::max(t, 0.0);
  }

  static constexpr int kMaxSteps = 256;
  double xs_, c_ = 0;
  int steps_;
  double cum_[kMaxSteps + 1] = {};
};

/// Position of the cut x (in units of the disc radius, along D12) such that the part
/// {u > x + g/2} and the part {u < x - g/2} have areas in the ratio m1 : m0.
double fork_cut(double m0, double m1, double g) {
  const double f1 = m1 / (m0 + m1);
  double lo = -1.0 + g / 2, hi = 1.0 - g / 2;
  for (int it = 0; it < 40; ++it) {
    const double x = 0.5 * (lo + hi);
    const double a1 = segment_area(x + g / 2), a0 = segment_area(-x + g / 2);
    if (a1 / (a0 + a1) > f1) {
      lo = x;  // c1's part too large: move the cut towards c1
    } else {
      hi = x;
    }
  }
  return 0.5 * (lo + hi);
}

struct RelaxResultSlot {
  std::uint32_t steps = 0;
  bool converged = false;
  bool valid = false;
};

// ---------------------------------------------------------------------------------------------
// Working memory of one thread (reused across nodes; fully reset for every node).

struct Scratch {
  // Relaxation state in cell order (structure of arrays), with the double buffers.
  std::vector<float> x, y, vx, vy, nx, ny, nvx, nvy, move2;
  std::vector<std::uint8_t> active, nactive;  // moved at least half the tolerance last step
  std::vector<std::uint8_t> live;             // active or next to an active particle
  std::vector<std::uint8_t> coincident;       // shares its position with a neighbour
  std::vector<std::uint32_t> orig, norig;  // cell-order slot -> local particle index
  std::vector<std::uint32_t> nbr_begin, nbr_end, nbr;
  // Grids.
  std::vector<std::uint32_t> cell_start, cell_item, cell_of, fill, slot_cell;
  // New strands.
  std::vector<dvec2> candidates;
  std::vector<double> cand_dist;
  std::vector<std::uint32_t> sort_buf;
  struct PairSlot {
    double d2;
    std::uint32_t particle, slot;
  };
  std::vector<PairSlot> pairs;  // small forks: particle-slot distances
  // Relaxed tip patterns by particle count (see tip_pattern()).
  std::vector<std::vector<dvec2>> tip_pattern;
  std::vector<RelaxResultSlot> tip_result;
  double tips_cpu = 0, placement_cpu = 0, relaxation_cpu = 0;
};

/// Counting-sort grid over [-extent, extent]^2 with square cells of at least `cell`.
struct Grid {
  double origin = 0, inv_cell = 0;
  int side = 1;
  [[nodiscard]] int coord(double v) const { return std::clamp(int((v - origin) * inv_cell), 0, side - 1); }
  [[nodiscard]] std::uint32_t cell(double px, double py) const { return std::uint32_t(coord(py) * side + coord(px)); }
};

Grid make_grid(double extent, double cell) {
  Grid g;
  g.origin = -extent;
  g.side = std::clamp(int(std::floor(2.0 * extent / cell)), 1, 2048);
  g.inv_cell = g.side / (2.0 * extent);
  return g;
}

/// Sorts the n items by the cell ids in sc.cell_of: sc.cell_start (#cells+1) and sc.cell_item
/// (#n, item indices grouped by cell, in index order within a cell: deterministic).
void counting_sort(const Grid& g, std::size_t n, Scratch& sc) {
  const std::size_t cells = std::size_t(g.side) * std::size_t(g.side);
  sc.cell_start.assign(cells + 1, 0);
  for (std::size_t i = 0; i < n; ++i) ++sc.cell_start[sc.cell_of[i] + 1];
  for (std::size_t c = 0; c < cells; ++c) sc.cell_start[c + 1] += sc.cell_start[c];
  sc.fill.assign(sc.cell_start.begin(), sc.cell_start.end() - 1);
  sc.cell_item.resize(n);
  for (std::size_t i = 0; i < n; ++i) sc.cell_item[sc.fill[sc.cell_of[i]]++] = std::uint32_t(i);
}

Grid build_grid(std::span<const dvec2> pts, double extent, double cell, Scratch& sc) {
  const Grid g = make_grid(extent, cell);
  sc.cell_of.resize(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) sc.cell_of[i] = g.cell(pts[i].x, pts[i].y);
  counting_sort(g, pts.size(), sc);
  return g;
}

/// Clouds at least this large are relaxed with a parallel loop over their particles (the
/// trunk's clouds would otherwise serialize the end of the bottom-up sweep). Each particle's
/// force is summed over its own neighbour list in a fixed order, so the result does not
/// depend on how the particles are split over threads.
constexpr std::size_t kParallelCloud = 4096;
/// Squared distance (in lambda^2) below which two particles count as coincident.
constexpr float kCoincident2 = 1e-12f;
/// Tips with at most this many particles take a cached relaxed pattern.
constexpr std::uint32_t kTipCache = 256;
/// Forks with at most this many particles take the relaxed pattern too (snap_to_pattern).
constexpr std::uint32_t kSmallFork = 32;

template <class F>
void for_particles(std::size_t m, F&& f) {
  if (m < kParallelCloud) {
    f(std::size_t(0), m);
  } else {
    // Isolated: while it waits, this thread must not pick up another node of the outer loop,
    // which would reuse (and overwrite) this thread's scratch memory.
    tbb::this_task_arena::isolate([&] {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m, 1024),
                        [&](const tbb::blocked_range<std::size_t>& r) { f(r.begin(), r.end()); });
    });
  }
}

/// Sorts the relaxation state by grid cell and rebuilds every particle's neighbour list: all
/// others within `radius`, in slot order. Cells are half the radius wide, so the candidates
/// of a particle are the five rows of five cells around its own (contiguous slot ranges after
/// the sort), 30% fewer than with cells of the full radius.
void rebuild_neighbours(std::size_t m, float extent, float radius, Scratch& sc) {
  const Grid g = make_grid(extent, 0.5f * radius);
  sc.cell_of.resize(m);
  for (std::size_t a = 0; a < m; ++a) sc.cell_of[a] = g.cell(sc.x[a], sc.y[a]);
  counting_sort(g, m, sc);
  sc.slot_cell.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    const std::uint32_t a = sc.cell_item[k];
    sc.nx[k] = sc.x[a];
    sc.ny[k] = sc.y[a];
    sc.nvx[k] = sc.vx[a];
    sc.nvy[k] = sc.vy[a];
    sc.norig[k] = sc.orig[a];
    sc.nactive[k] = sc.active[a];
    sc.slot_cell[k] = sc.cell_of[a];
  }
  sc.x.swap(sc.nx);
  sc.y.swap(sc.ny);
  sc.vx.swap(sc.nvx);
  sc.vy.swap(sc.nvy);
  sc.orig.swap(sc.norig);
  sc.active.swap(sc.nactive);
  const float r2 = radius * radius;
  const int side = g.side;
  auto row = [&](int y, int cx, std::uint32_t& b, std::uint32_t& e) {
    b = sc.cell_start[std::size_t(y) * side + std::max(cx - 2, 0)];
    e = sc.cell_start[std::size_t(y) * side + std::min(cx + 2, side - 1) + 1];
  };
  // Every list gets a fixed capacity: the most candidates any particle has (+1 spare slot),
  // so the lists are written in one pass, in parallel for large clouds, without counting.
  std::uint32_t capacity = 1;
  for (int cy = 0; cy < side; ++cy) {
    for (int cx = 0; cx < side; ++cx) {
      const std::size_t c = std::size_t(cy) * side + cx;
      if (sc.cell_start[c + 1] == sc.cell_start[c]) continue;
      std::uint32_t block = 0;
      for (int y = std::max(cy - 2, 0); y <= std::min(cy + 2, side - 1); ++y) {
        std::uint32_t b, e;
        row(y, cx, b, e);
        block += e - b;
      }
      capacity = std::max(capacity, block + 1);
    }
  }
  sc.nbr_begin.resize(m);
  sc.nbr_end.resize(m);
  sc.coincident.resize(m);
  sc.nbr.resize(m * std::size_t(capacity));
  for_particles(m, [&](std::size_t kb, std::size_t ke) {
    for (std::size_t k = kb; k < ke; ++k) {
      const int c = int(sc.slot_cell[k]);
      const int cx = c % side, cy = c / side;
      const float px = sc.x[k], py = sc.y[k];
      std::uint32_t* out = sc.nbr.data() + k * capacity;
      std::uint32_t at_same_place = 0;  // counts the particle itself
      for (int y = std::max(cy - 2, 0); y <= std::min(cy + 2, side - 1); ++y) {
        std::uint32_t b, e;
        row(y, cx, b, e);
        // Branch-free: every candidate is written, the output advances only for neighbours
        // (a mispredicted branch per candidate costs more than the store).
        for (std::uint32_t j = b; j < e; ++j) {
          const float dx = px - sc.x[j], dy = py - sc.y[j];
          const float d2 = dx * dx + dy * dy;
          *out = j;
          out += (d2 < r2) & (j != k);
          at_same_place += d2 <= kCoincident2;
        }
      }
      sc.coincident[k] = at_same_place > 1;
      sc.nbr_begin[k] = std::uint32_t(k * capacity);
      sc.nbr_end[k] = std::uint32_t(out - sc.nbr.data());
    }
  });
}

/// Relaxes `pos` inside the disc of radius `wall_m` (metres; lambda = the cloud's length).
/// Returns the number of steps taken and whether the last step moved less than the tolerance.
struct RelaxResult {
  std::uint32_t steps = 0;
  bool converged = false;
};

RelaxResult relax(std::span<dvec2> pos, double wall_m, double lambda, const ParticleParams& p, Scratch& sc) {
  RelaxResult res;
  const std::size_t m = pos.size();
  if (m == 0 || p.max_steps == 0) return res;
  // Simulated in units of lambda, in single precision (ample for clouds up to millions of
  // particles; the result is stored back in double).
  using real = float;
  const real h = real(p.repulsion_radius);
  const real h2 = h * h, kappa = real(0.5) / h;
  const real vmax = real(p.max_velocity), vmax2 = vmax * vmax;
  const real gain = real(p.step_size);
  const real tol2 = real(p.move_tolerance * p.move_tolerance);
  const real skin = real(p.neighbour_skin);
  const real wall = real(wall_m / lambda), wall2 = wall * wall;
  const real mirror = wall + real(p.wall_offset);
  const real inner = std::max(real(0), mirror - real(0.5) * h), inner2 = inner * inner;
  const real tiny2 = real(1e-12);
  const real damping = real(p.damping);
  const double inv_lambda = 1.0 / lambda;
  for (auto* v : {&sc.x, &sc.y, &sc.vx, &sc.vy, &sc.nx, &sc.ny, &sc.nvx, &sc.nvy, &sc.move2}) v->resize(m);
  sc.orig.resize(m);
  sc.norig.resize(m);
  sc.active.resize(m);
  sc.nactive.resize(m);
  const real rest2 = real(0.25) * tol2;
  for (std::size_t a = 0; a < m; ++a) {
    sc.x[a] = real(pos[a].x * inv_lambda);
    sc.y[a] = real(pos[a].y * inv_lambda);
    sc.vx[a] = sc.vy[a] = 0;
    sc.active[a] = 1;
    sc.orig[a] = std::uint32_t(a);
  }
  // Verlet lists of the pairs within repulsion_radius + skin, rebuilt when the particles may
  // have closed the skin (twice the summed largest moves since the last rebuild) and at least
  // every rebuild_every steps: until then no pair within the repulsion radius is missing.
  real moved = skin;
  std::uint32_t since = 0;
  for (std::uint32_t step = 0; step < p.max_steps; ++step) {
    if (2 * moved >= skin || since >= p.rebuild_every) {
      rebuild_neighbours(m, wall + 1, h + skin, sc);
      moved = 0;
      since = 0;
    }
    ++since;
    // A particle at rest (it and all its neighbours moved less than half the tolerance in the
    // last step) stays put: late steps only touch the region still settling. The lists are
    // symmetric, so marking the neighbours of the active particles marks exactly the
    // particles with an active neighbour (the same byte may be set by several threads).
    sc.live.assign(m, 0);
    for_particles(m, [&](std::size_t b, std::size_t e) {
      for (std::size_t a = b; a < e; ++a) {
        if (!sc.active[a]) continue;
        std::atomic_ref<std::uint8_t>(sc.live[a]).store(1, std::memory_order_relaxed);
        for (std::uint32_t k = sc.nbr_begin[a], ke = sc.nbr_end[a]; k < ke; ++k) {
          std::atomic_ref<std::uint8_t>(sc.live[sc.nbr[k]]).store(1, std::memory_order_relaxed);
        }
      }
    });
    const real* xs = sc.x.data();
    const real* ys = sc.y.data();
    for_particles(m, [&](std::size_t b, std::size_t e) {
      for (std::size_t a = b; a < e; ++a) {
        const real px = xs[a], py = ys[a];
        if (!sc.live[a]) {
          sc.nx[a] = px;
          sc.ny[a] = py;
          sc.nvx[a] = sc.nvy[a] = 0;
          sc.move2[a] = 0;
          sc.nactive[a] = 0;
          continue;
        }
        // Repulsion kappa (h^2 / d - d) along each pair (kappa = 1 / 2h): zero at h, the slope
        // of (1 - d/h) near h, unbounded as d -> 0 so close pairs separate first; one division
        // and no square root, branch-free (the select compiles to maxss).
        real fx = 0, fy = 0;
        const std::uint32_t* nb = sc.nbr.data();
        for (std::uint32_t k = sc.nbr_begin[a], ke = sc.nbr_end[a]; k < ke; ++k) {
          const std::uint32_t j = nb[k];
          const real dx = px - xs[j], dy = py - ys[j];
          const real d2 = dx * dx + dy * dy;
          const real t = h2 / (d2 + tiny2) - real(1);
          const real w = kappa * (t > 0 ? t : real(0));
          fx += dx * w;
          fy += dy * w;
        }
        if (sc.coincident[a]) {
          // Coincident particles (found when the lists are built: placements never produce
          // them, degenerate input might): push apart along a direction fixed by their
          // indices, as long as they stay coincident.
          for (std::uint32_t k = sc.nbr_begin[a], ke = sc.nbr_end[a]; k < ke; ++k) {
            const std::uint32_t j = nb[k];
            const real dx = px - xs[j], dy = py - ys[j];
            if (dx * dx + dy * dy > kCoincident2) continue;
            const std::uint32_t lo = std::min(sc.orig[a], sc.orig[j]), hi = std::max(sc.orig[a], sc.orig[j]);
            const double ang = kGoldenAngle * double(lo + 3 * hi);
            const real sgn = sc.orig[a] == lo ? real(1) : real(-1);
            fx += sgn * real(std::cos(ang));
            fy += sgn * real(std::sin(ang));
          }
        }
        // The wall repels like a mirror image of the particle: at distance g from the mirror
        // circle the particle feels the pair force of distance 2 g, pointing inwards.
        const real r2 = px * px + py * py;
        if (r2 > inner2 && r2 > 0) {
          const real rho = std::sqrt(r2);
          const real gap = std::max(real(2) * (mirror - rho), real(1e-3));
          const real w = kappa * std::max(real(0), h2 / gap - gap) / rho;
          fx -= px * w;
          fy -= py * w;
        }
        real vx = damping * sc.vx[a] + gain * fx, vy = damping * sc.vy[a] + gain * fy;
        const real v2 = vx * vx + vy * vy;
        if (v2 > vmax2) {
          const real k = vmax / std::sqrt(v2);
          vx *= k;
          vy *= k;
        }
        real qx = px + vx, qy = py + vy;
        const real q2 = qx * qx + qy * qy;
        if (q2 > wall2) {
          const real k = wall / std::sqrt(q2);
          qx *= k;
          qy *= k;
          vx = qx - px;
          vy = qy - py;
        }
        sc.nx[a] = qx;
        sc.ny[a] = qy;
        sc.nvx[a] = vx;
        sc.nvy[a] = vy;
        sc.move2[a] = vx * vx + vy * vy;
        sc.nactive[a] = sc.move2[a] >= rest2;
      }
    });
    sc.x.swap(sc.nx);
    sc.y.swap(sc.ny);
    sc.vx.swap(sc.nvx);
    sc.vy.swap(sc.nvy);
    sc.active.swap(sc.nactive);
    const real max_move2 = *std::max_element(sc.move2.begin(), sc.move2.begin() + std::ptrdiff_t(m));
    moved += std::sqrt(max_move2);
    ++res.steps;
    if (max_move2 < tol2) {
      res.converged = true;
      break;
    }
  }
  for (std::size_t a = 0; a < m; ++a) pos[sc.orig[a]] = dvec2(double(sc.x[a]) * lambda, double(sc.y[a]) * lambda);
  return res;
}

/// Sunflower spiral of m points in the disc of radius `wall`, rotated by `angle`.
void sunflower(std::span<dvec2> out, double wall, double angle) {
  const double m = double(out.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    const double rho = wall * std::sqrt((double(k) + 0.5) / m);
    const double a = angle + kGoldenAngle * double(k);
    out[k] = dvec2(rho * std::cos(a), rho * std::sin(a));
  }
}

/// Writes `fresh` new particles after the `carried` ones of `pos` (pos.size() = carried +
/// fresh): the sunflower candidates (full count) farthest from the carried particles.
void insert_new_strands(std::span<dvec2> pos, std::size_t carried, double wall, double angle, Scratch& sc) {
  const std::size_t m = pos.size(), fresh = m - carried;
  sc.candidates.resize(m);
  sunflower(sc.candidates, wall, angle);
  if (carried == 0) {
    std::copy(sc.candidates.begin(), sc.candidates.end(), pos.begin());
    return;
  }
  // Distance from each candidate to the nearest carried particle (grid with about one
  // carried particle per cell, searched in growing rings).
  const std::span<const dvec2> old(pos.data(), carried);
  const double extent = wall * (1.0 + 1e-9) + 1e-300;
  const double cell = std::max(wall * std::sqrt(kPi / double(carried)), 1e-12 * wall + 1e-300);
  const Grid g = build_grid(old, extent, cell, sc);
  sc.cand_dist.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    const dvec2 q = sc.candidates[k];
    const int qx = g.coord(q.x), qy = g.coord(q.y);
    double best2 = std::numeric_limits<double>::infinity();
    for (int ring = 0; ring <= g.side; ++ring) {
      // Every point outside the rings searched so far is at least (ring - 1) cells away.
      const double reach = double(ring - 1) / g.inv_cell;
      if (ring > 0 && reach > 0 && reach * reach > best2) break;
      for (int y = qy - ring; y <= qy + ring; ++y) {
        if (y < 0 || y >= g.side) continue;
        const bool edge_row = y == qy - ring || y == qy + ring;
        for (int x = qx - ring; x <= qx + ring; x += (edge_row ? 1 : 2 * ring)) {
          if (x >= 0 && x < g.side) {
            const std::size_t c = std::size_t(y) * g.side + x;
            for (std::uint32_t a = sc.cell_start[c]; a < sc.cell_start[c + 1]; ++a) {
              const dvec2 d = q - old[sc.cell_item[a]];
              best2 = std::min(best2, d.x * d.x + d.y * d.y);
            }
          }
          if (ring == 0) break;
        }
      }
    }
    sc.cand_dist[k] = best2;
  }
  std::vector<std::uint32_t>& order = sc.sort_buf;
  order.resize(m);
  for (std::size_t k = 0; k < m; ++k) order[k] = std::uint32_t(k);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return sc.cand_dist[a] != sc.cand_dist[b] ? sc.cand_dist[a] > sc.cand_dist[b] : a < b;
  });
  std::sort(order.begin(), order.begin() + std::ptrdiff_t(fresh));
  for (std::size_t t = 0; t < fresh; ++t) pos[carried + t] = sc.candidates[order[t]];
}

// ---------------------------------------------------------------------------------------------
// The per-node work.

class CloudBuilder {
 public:
  CloudBuilder(const Skeleton& sk, const ParticleParams& p, ParticleField& f, std::vector<std::uint8_t>& converged,
               std::vector<std::uint8_t>& flags)
      : sk_(sk), p_(p), f_(f), converged_(converged), flags_(flags) {}

  void build(NodeId n, Scratch& sc) {
    Stopwatch watch;
    const std::size_t i = n.idx();
    const std::uint32_t begin = f_.node_begin[i];
    const std::uint32_t m = f_.node_begin[i + 1] - begin;
    const std::uint32_t carried = f_.new_begin[i];
    const std::span<dvec2> pos(f_.position.data() + begin, m);
    const double r = sk_.radius[i];
    const double lambda = r / std::sqrt(double(m));
    const double wall = f_.disc_radius[i];
    Rng rng(derive_seed(p_.seed, i));
    const NodeId c0 = sk_.children[i][0], c1 = sk_.children[i][1];

    // Strand ids: [c0 | c1 | new].
    std::uint32_t j = 0;
    for (NodeId c : {c0, c1}) {
      if (!c.valid()) continue;
      const std::uint32_t cb = f_.node_begin[c.idx()], ce = f_.node_begin[c.idx() + 1];
      for (std::uint32_t k = cb; k < ce; ++k) f_.strand[begin + j++] = f_.strand[k];
    }
    for (std::uint32_t k = 0; j < m; ++j, ++k) f_.strand[begin + j] = StrandId(f_.strand_begin[i] + k);

    bool skip_relaxation = false;
    if (!c0.valid()) {
      if (r < f_.spacing) flags_[i] |= kThinTip;
      const double angle = rng.uniform(0.0, 2.0 * kPi);
      if (m <= kTipCache) {
        // Small tips: the relaxed pattern for m particles, rotated by the node's angle and
        // scaled by its lambda (the simulation is rotation- and scale-invariant).
        const RelaxResultSlot& res = tip_pattern(m, sc);
        const std::vector<dvec2>& pat = sc.tip_pattern[m];
        const double c = std::cos(angle) * lambda, sn = std::sin(angle) * lambda;
        for (std::uint32_t k = 0; k < m; ++k) pos[k] = dvec2(c * pat[k].x - sn * pat[k].y, sn * pat[k].x + c * pat[k].y);
        f_.steps[i] = res.steps;
        converged_[i] = res.converged ? 1 : 0;
        sc.tips_cpu += watch.lap();
        return;
      }
      sunflower(pos, wall, angle);
      sc.tips_cpu += watch.lap();
    } else {
      if (!c1.valid()) {
        carry(n, c0, pos);
        skip_relaxation = carried == m && converged_[c0.idx()];
      } else {
        const dvec2 u = place_fork(n, c0, c1, pos);
        if (carried == m && m <= kSmallFork) snap_to_pattern(n, u, lambda, pos, sc);
      }
      if (carried < m) insert_new_strands(pos, carried, wall, rng.uniform(0.0, 2.0 * kPi), sc);
      sc.placement_cpu += watch.lap();
    }
    RelaxResult rr;
    if (skip_relaxation) {
      rr.converged = true;
    } else {
      rr = relax(pos, wall, lambda, p_, sc);
    }
    f_.steps[i] = rr.steps;
    converged_[i] = rr.converged ? 1 : 0;
    sc.relaxation_cpu += watch.lap();
  }

 private:
  /// The relaxed tip pattern of m particles in units of lambda (computed once per thread;
  /// a pure function of m and the parameters, so every thread gets the same bits).
  const RelaxResultSlot& tip_pattern(std::uint32_t m, Scratch& sc) {
    if (sc.tip_pattern.size() <= m) {
      sc.tip_pattern.resize(m + 1);
      sc.tip_result.resize(m + 1);
    }
    RelaxResultSlot& slot = sc.tip_result[m];
    if (!slot.valid) {
      std::vector<dvec2>& pat = sc.tip_pattern[m];
      pat.resize(m);
      const double wall = std::sqrt(double(m)) - p_.wall_margin;  // r / lambda = sqrt(m)
      sunflower(pat, wall, 0.0);
      const RelaxResult rr = relax(pat, wall, 1.0, p_, sc);
      slot = {rr.steps, rr.converged, true};
    }
    return slot;
  }

  /// One child: rotate into the parent's frame and scale to the parent's disc.
  void carry(NodeId n, NodeId c, std::span<dvec2> pos) {
    const std::size_t i = n.idx(), k = c.idx();
    check_direction(n, c);
    const Map2 map = carry_map(sk_.frame[k], sk_.frame[i]);
    const double scale = f_.disc_radius[i] / f_.disc_radius[k];
    const std::uint32_t cb = f_.node_begin[k], cm = f_.count(c);
    for (std::uint32_t j = 0; j < cm; ++j) pos[j] = scale * map(f_.position[cb + j]);
  }

  /// Flags a child edge that points back into the parent's half space.
  dvec3 check_direction(NodeId n, NodeId c) {
    const dvec3 d = normalize_or(sk_.position[c.idx()] - sk_.position[n.idx()], sk_.frame[c.idx()].tangent);
    if (glm::dot(d, sk_.frame[n.idx()].tangent) < 0) flags_[n.idx()] |= kBackwardChild;
    return d;
  }

  /// Fork: each child's cloud into its part of the parent disc (see the file comment).
  /// Places a fork's bundles (see the file comment); returns the child-to-child direction.
  dvec2 place_fork(NodeId n, NodeId c0, NodeId c1, std::span<dvec2> pos) {
    const std::size_t i = n.idx();
    const Frame& fr = sk_.frame[i];
    const dvec3 d0 = check_direction(n, c0), d1 = check_direction(n, c1);
    const double reach = sk_.edge_length(c0) + sk_.edge_length(c1);
    // Child-to-child direction in the parent plane, with fallbacks for degenerate forks.
    dvec2 u = fr.to_local(sk_.position[c1.idx()] - sk_.position[c0.idx()]);
    if (glm::length(sk_.position[c1.idx()] - sk_.position[c0.idx()]) <= 1e-9 * reach) {
      flags_[i] |= kForkChildrenCoincide;
    }
    if (glm::dot(d0, d1) > std::cos(kPi / 180.0)) flags_[i] |= kForkChildrenColinear;
    if (!(glm::length(u) > 1e-6 * reach)) {
      u = fr.to_local(d1 - d0);
      if (!(glm::length(u) > 1e-6)) {
        u = dvec2(1, 0);
        flags_[i] |= kForkDirectionDegenerate;
      }
    }
    u = glm::normalize(u);
    const dvec2 w(-u.y, u.x);

    const double wall = f_.disc_radius[i];
    const std::uint32_t m = f_.count(n);
    const double lambda = sk_.radius[i] / std::sqrt(double(m));
    const double m0 = f_.count(c0), m1 = f_.count(c1);
    const double gap = std::min(p_.fork_gap * lambda / wall, 0.5);  // in units of the wall radius
    const double cut = fork_cut(m0, m1, gap);

    std::uint32_t j = 0;
    for (int side = 0; side < 2; ++side) {
      const NodeId c = side == 0 ? c0 : c1;
      const double sigma = side == 0 ? -1.0 : 1.0;
      // In mirrored coordinates (sigma * u) the child's part is {x > start}.
      const double start = sigma * cut + gap / 2;
      const StarMap star(start, 2 * int(f_.count(c)));
      const Map2 map = carry_map(sk_.frame[c.idx()], fr);
      const double inv_r = 1.0 / f_.disc_radius[c.idx()];
      const std::uint32_t cb = f_.node_begin[c.idx()], cm = f_.count(c);
      for (std::uint32_t k = 0; k < cm; ++k, ++j) {
        dvec2 x = inv_r * map(f_.position[cb + k]);
        const double len = glm::length(x);
        if (len > 1.0) x /= len;
        const double a = sigma * glm::dot(x, u), b = glm::dot(x, w);
        const dvec2 q = star(a, b);
        pos[j] = wall * (sigma * q.x * u + q.y * w);
      }
    }
    return u;
  }

  /// Small forks: a handful of particles mapped onto half discs sit on the boundaries of the
  /// two parts and leave the middles empty, and with so few particles the relaxation can
  /// stop in such a state (every particle is farther than the repulsion radius from the
  /// hole). Instead the fork takes the relaxed tip pattern of its count: the slots with the
  /// smaller coordinates along u go to the main bundle, the others to the lateral one, and
  /// within each side the particles take the slots nearest to their mapped positions (greedy,
  /// closest pairs first), which keeps the bundle's arrangement.
  void snap_to_pattern(NodeId n, dvec2 u, double lambda, std::span<dvec2> pos, Scratch& sc) {
    const std::uint32_t m = std::uint32_t(pos.size());
    tip_pattern(m, sc);
    const std::vector<dvec2>& pat = sc.tip_pattern[m];
    std::uint32_t order[kSmallFork];
    for (std::uint32_t k = 0; k < m; ++k) order[k] = k;
    std::sort(order, order + m, [&](std::uint32_t a, std::uint32_t b) {
      const double ua = glm::dot(pat[a], u), ub = glm::dot(pat[b], u);
      return ua != ub ? ua < ub : a < b;
    });
    const std::uint32_t n0 = f_.count(sk_.children[n.idx()][0]);
    dvec2 placed[kSmallFork];
    for (int side = 0; side < 2; ++side) {
      const std::uint32_t b = side == 0 ? 0 : n0, e = side == 0 ? n0 : m;
      using Pair = Scratch::PairSlot;
      std::vector<Pair>& pairs = sc.pairs;
      pairs.clear();
      for (std::uint32_t a = b; a < e; ++a) {
        for (std::uint32_t k = b; k < e; ++k) {
          const dvec2 d = pos[a] - lambda * pat[order[k]];
          pairs.push_back({glm::dot(d, d), a, order[k]});
        }
      }
      std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
        return x.d2 != y.d2 ? x.d2 < y.d2 : (x.particle != y.particle ? x.particle < y.particle : x.slot < y.slot);
      });
      std::uint64_t used_particle = 0, used_slot = 0;
      for (const Pair& q : pairs) {
        if ((used_particle >> q.particle & 1) || (used_slot >> q.slot & 1)) continue;
        used_particle |= std::uint64_t(1) << q.particle;
        used_slot |= std::uint64_t(1) << q.slot;
        placed[q.particle] = lambda * pat[q.slot];
      }
    }
    std::copy(placed, placed + m, pos.begin());
  }

  const Skeleton& sk_;
  const ParticleParams& p_;
  ParticleField& f_;
  std::vector<std::uint8_t>& converged_;
  std::vector<std::uint8_t>& flags_;
};

void add_warnings(const Skeleton& sk, const std::vector<std::uint8_t>& flags, Warnings& w) {
  struct Kind {
    NodeFlag flag;
    const char* key;
    const char* message;
  };
  static constexpr Kind kinds[] = {
      {kThinTip, "thin_tip",
       "tip thinner than one particle spacing: its disc is packed with min_particles particles, denser than s"},
      {kBackwardChild, "child_points_backwards",
       "child edge points back into its parent's half space: its bundle is turned into the parent's plane by the "
       "minimal rotation (no oblique projection)"},
      {kForkChildrenCoincide, "fork_children_coincide",
       "fork children at the same position: bundles placed side by side along the difference of their directions"},
      {kForkChildrenColinear, "fork_children_colinear",
       "fork children in the same direction (within 1 degree): bundles placed side by side across the plane"},
      {kForkDirectionDegenerate, "fork_direction_degenerate",
       "fork without a child-to-child direction in the parent plane: bundles placed side by side along the "
       "frame normal"},
  };
  for (const Kind& k : kinds) {
    for (std::size_t i = 0; i < flags.size(); ++i) {
      if (flags[i] & k.flag) w.add(k.key, k.message, sk.describe(NodeId(i)));
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------

std::uint32_t parent_index(const Skeleton& skeleton, const ParticleField& field, NodeId child, std::uint32_t j) {
  const NodeId p = skeleton.parent[child.idx()];
  const NodeId c0 = skeleton.children[p.idx()][0];
  return c0 == child ? j : field.count(c0) + j;
}

SpacingChoice choose_spacing(const Skeleton& sk, const ParticleParams& p) {
  validate_params(p);
  SM_CHECK(!sk.empty(), "choose_spacing: empty skeleton");
  std::vector<std::uint64_t> count;
  SpacingChoice out;
  if (p.spacing > 0) {
    out.spacing = p.spacing;
    out.root_strands = root_count(sk, p.spacing, p, count);
    return out;
  }
  // Default: the median tip gets exactly min_particles particles.
  std::vector<double> tips;
  double r_max = 0;
  for (std::size_t i = 0; i < sk.size(); ++i) {
    if (sk.is_tip(NodeId(i))) tips.push_back(sk.radius[i]);
    r_max = std::max(r_max, sk.radius[i]);
  }
  std::sort(tips.begin(), tips.end());
  const double s0 = tips[tips.size() / 2] / std::sqrt(double(p.min_particles));
  std::uint64_t target = p.root_strands;
  if (target == 0) {
    const std::uint64_t n0 = root_count(sk, s0, p, count);
    if (n0 <= p.max_root_strands) return {s0, std::size_t(n0)};
    target = p.max_root_strands;
  }
  // Bisection in log s for the root count (non-increasing in s). At s_hi every node has its
  // minimum (no new strands, tips at min_particles): the floor of what any s can give.
  double hi = 4.0 * r_max;
  const std::uint64_t floor_count = root_count(sk, hi, p, count);
  target = std::max(target, floor_count);
  double lo = hi;
  for (int it = 0; it < 2000 && root_count(sk, lo, p, count) <= target; ++it) lo *= 0.5;
  for (int it = 0; it < 40; ++it) {
    const double mid = std::sqrt(lo * hi);
    if (root_count(sk, mid, p, count) > target) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  // hi gives at most the target; lo more. Take the closer one (ties: hi).
  const std::uint64_t n_hi = root_count(sk, hi, p, count), n_lo = root_count(sk, lo, p, count);
  const bool take_lo = p.root_strands > 0 && n_lo - target < target - n_hi;
  out.spacing = take_lo ? lo : hi;
  out.root_strands = std::size_t(take_lo ? n_lo : n_hi);
  return out;
}

ParticleField compute_particles(const Skeleton& sk, const ParticleParams& p, const ProgressFn& progress) {
  validate_params(p);
  if (sk.empty()) throw InvalidInputError("compute_particles: the skeleton has no nodes");
  Stopwatch total;
  Stopwatch watch;
  ParticleField f;
  const SpacingChoice choice = choose_spacing(sk, p);
  const double s = choice.spacing;
  f.spacing = s;
  f.neighbour_distance = kHexDistance * s;
  f.stats.timings.add("spacing", watch.lap());
  if (p.root_strands > 0 && p.spacing == 0) {
    const double want = p.root_strands, got = double(choice.root_strands);
    if (std::abs(got - want) > std::max(0.05 * want, double(p.min_particles))) {
      f.stats.warnings.add("root_strands_unreachable",
                           "the requested root strand count cannot be reached (every tip has at least min_particles); "
                           "the root carries " + std::to_string(choice.root_strands) + " strands",
                           "requested " + std::to_string(p.root_strands));
    }
  }

  // Counts, ranges, strand ids.
  const std::size_t n = sk.size();
  const std::uint64_t cap = std::min<std::uint64_t>(p.max_total_particles, std::numeric_limits<std::uint32_t>::max() - 1);
  const Layout layout = count_layout(sk, s, p, cap + 1);
  if (layout.total > cap) {
    throw InvalidInputError("compute_particles: spacing " + std::to_string(s) + " m gives more than " +
                            std::to_string(cap) + " particles over " + std::to_string(n) +
                            " nodes (max_total_particles); use a larger spacing or fewer root strands");
  }
  f.node_begin.assign(n + 1, 0);
  f.strand_begin.assign(n + 1, 0);
  f.new_begin.assign(n, 0);
  f.steps.assign(n, 0);
  f.disc_radius.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    f.node_begin[i + 1] = f.node_begin[i] + std::uint32_t(layout.count[i]);
    f.strand_begin[i + 1] = f.strand_begin[i] + std::uint32_t(layout.fresh[i]);
    f.new_begin[i] = std::uint32_t(layout.count[i] - layout.fresh[i]);
    const double m = double(layout.count[i]);
    f.disc_radius[i] = sk.radius[i] * (1.0 - p.wall_margin / std::sqrt(m));
  }
  const std::size_t particles = f.node_begin[n];
  const std::size_t strands = f.strand_begin[n];
  f.position.assign(particles, dvec2(0));
  f.strand.assign(particles, StrandId());
  f.strand_start.resize(strands);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::uint32_t k = f.strand_begin[i]; k < f.strand_begin[i + 1]; ++k) f.strand_start[k] = NodeId(i);
  }
  f.stats.timings.add("layout", watch.lap());

  // Bottom-up in parallel: a node is built by the thread that finished its last child.
  std::vector<std::uint8_t> converged(n, 0), flags(n, 0);
  std::vector<std::atomic<std::uint32_t>> pending(n);
  std::vector<std::uint32_t> tips;
  for (std::size_t i = 0; i < n; ++i) {
    pending[i].store(std::uint32_t(sk.child_count(NodeId(i))), std::memory_order_relaxed);
    if (sk.is_tip(NodeId(i))) tips.push_back(std::uint32_t(i));
  }
  CloudBuilder builder(sk, p, f, converged, flags);
  tbb::enumerable_thread_specific<Scratch> scratch;
  std::atomic<std::size_t> done{0};
  tbb::spin_mutex progress_mutex;
  const std::size_t report_every = std::max<std::size_t>(1, n / 100);
  if (progress) progress("particles", 0.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tips.size(), 8), [&](const tbb::blocked_range<std::size_t>& range) {
    Scratch& sc = scratch.local();
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      NodeId node(tips[t]);
      for (;;) {
        builder.build(node, sc);
        if (progress) {
          const std::size_t d = done.fetch_add(1, std::memory_order_relaxed) + 1;
          if (d % report_every == 0) {
            tbb::spin_mutex::scoped_lock lock(progress_mutex);
            progress("particles", double(d) / double(n));
          }
        }
        const NodeId parent = sk.parent[node.idx()];
        if (!parent.valid()) break;
        // The last child to finish carries on with the parent (acq_rel: the parent sees
        // both children's clouds).
        if (pending[parent.idx()].fetch_sub(1, std::memory_order_acq_rel) != 1) break;
        node = parent;
      }
    }
  });
  if (progress) progress("particles", 1.0);
  f.stats.timings.add("clouds", watch.lap());
  double tips_cpu = 0, placement_cpu = 0, relaxation_cpu = 0;
  for (const Scratch& sc : scratch) {
    tips_cpu += sc.tips_cpu;
    placement_cpu += sc.placement_cpu;
    relaxation_cpu += sc.relaxation_cpu;
  }
  f.stats.timings.add("tips_cpu", tips_cpu);
  f.stats.timings.add("placement_cpu", placement_cpu);
  f.stats.timings.add("relaxation_cpu", relaxation_cpu);

  // Stats and warnings, in node order.
  ParticleStats& st = f.stats;
  st.nodes = n;
  st.strands = strands;
  st.particles = particles;
  for (std::size_t i = 0; i < n; ++i) {
    if (!sk.is_tip(NodeId(i))) st.new_strands += f.strand_begin[i + 1] - f.strand_begin[i];
    st.relaxation_steps += f.steps[i];
    if (f.steps[i] > 0) {
      ++st.relaxed_nodes;
      st.relaxed_particles += f.count(NodeId(i));
    }
    if (!converged[i]) ++st.unconverged_nodes;
  }
  add_warnings(sk, flags, st.warnings);
  f.stats.timings.add("total", total.elapsed());
  return f;
}

}  // namespace sm
