#pragma once
// Sizing field from the local feature size of the material interfaces (seed §5.3).
//
// A sizing field gives, at every point, the edge length (mm) an element centred there should have:
// small near thin features and strongly curved interfaces, growing away from them by at most
// `lipschitz` mm per mm, large far from every interface. It is computed on a regular sampling
// grid that covers the materials' box; values are float, mm.
//
// Sampling grid (sizingGrid):
//   The materials' grid has n_a voxels of spacing h_a along axis a; its box is the union of the
//   voxel cells. The sizing grid has m_a = max(1, round(n_a * sampling_rate)) samples per axis
//   whose cells tile exactly the same box: spacing h'_a = n_a h_a / m_a (= h_a / sampling_rate
//   whenever n_a * sampling_rate is a whole number), sample centres at cell centres, same
//   direction matrix. With sampling_rate 1 it is the materials' grid itself. `padding` adds that
//   many whole samples on every side (dims m_a + 2 padding, origin moved out by padding h'_a).
//   Array layout as Volume.h: data[i + nx*(j + ny*k)], 0-based. All distances below are
//   Euclidean in mm in the grid's own frame (index * spacing, so anisotropic spacing counts and a
//   rotated grid gives the same distances).
//
// Stages (named, timed, reported through Progress):
//   sample       the dominant material of every sample = argmax of MaterialSet::sample at the
//                sample centre (ties to the lower material index). A padding sample takes the
//                material (and values) of the nearest in-grid sample: the materials are extended
//                constantly beyond the box, so an interface that reaches the box continues
//                straight through the padding, and the padding itself never adds an interface.
//   interfaces   an interface edge joins two 6-neighbour samples with different dominant
//                materials A (at p) and B (at q). Its interface point is subvoxel: the zero of
//                the linear interpolation of f_A - f_B along the edge,
//                  t = g_p / (g_p - g_q),  g = f_A - f_B  (g_p >= 0 >= g_q; t = 1/2 if both 0).
//                The endpoints of interface edges are the interface samples; each keeps the
//                interface point nearest to it among its own edges, and the interface normal
//                there: the gradient of f_A - f_B (A, B of that edge) fitted by least squares
//                (linear with intercept) to the interface samples of its 3x3x3 block (the edge's
//                axis when the fit is degenerate). The box is not an interface.
//   distance     exact Euclidean feature transform to the interface samples (separable lower
//                envelope of parabolas, one pass per axis, Felzenszwalb-Huttenlocher style):
//                every sample x gets its nearest interface sample s(x). Its closest interface
//                point cp(x) is the foot of x on the tangent plane (point, normal) kept by s(x),
//                moved back to within 1.5 sample spacings (the largest) of that point. Feet
//                rather than the discrete points themselves keep neighbouring closest points
//                consistent: on a plane the feet of two samples are exactly as far apart as the
//                samples' tangential offset.
//   medial       medial points from the divergence of the closest points. A pair of
//                26-neighbour samples x, n of the same dominant material (the interfaces
//                themselves are never medial) is medial when a = cp(x), b = cp(n) satisfy
//                  (1) |a - b| > 1.5 |x - n|      (closest points spread faster than the samples:
//                                                  along a plane they spread exactly |x - n|), and
//                  (2) the separation angle at y between a - y and b - y exceeds 120 degrees,
//                where y is the point of segment [x, n] equidistant from a and b (the bisector of
//                a and b crossing the segment; pairs whose bisector does not cross it, i.e.
//                (n - x).(b - a) <= 0, are not medial). y is the medial point; it is kept by the
//                nearer of x and n (x when y is the midpoint and x has the lower index; a sample
//                keeping several keeps the one nearest to it). Medial samples are the samples
//                keeping one. Why these numbers: inside a sphere (1) holds in a ball of 2/3 of
//                the radius, (2) only next to the centre; with 26-neighbour pairs some pair sees
//                the centre of a sphere under >= 135 degrees wherever the centre lies between
//                samples (>= 141 in a one-slice 2-D grid), while with 6-neighbours it can be 71.
//                A slab or layer gives 180 degrees. Inside a wedge of opening angle w the
//                bisector sees 180 - w degrees: right-angle edges of a voxelised surface (90)
//                and 120-degree triple junctions (60) do not count, wedges sharper than 60
//                degrees do, and there the feature size falls towards the floor below at the
//                edge. Criterion (1) needs the closest points to differ by 1.5 sample spacings,
//                so it misses layers thinner than about 1.5 samples; for those, a sample whose
//                two 6-neighbours along an axis both have other materials, and at least two of
//                whose four neighbours across that axis are such samples of its material (a
//                sheet or a tube one sample thick, not a one-sample bump of a voxelised
//                surface), keeps its own centre as medial point.
//   feature size the local feature size at an interface sample s is the distance from its
//                interface point to the nearest medial point (a second exact feature transform,
//                seeds = medial samples, then the distance to the medial point that sample keeps),
//                floored at half the smallest sample spacing (the grid's resolution), times
//                feature_scaling, capped at the unbounded size U (below).
//   lipschitz    s(x) = min over interface samples p of ( lfs(p) + lipschitz * d26(x, p) ), d26
//                the length of the shortest path from p to x through the 26-neighbourhood graph
//                of the grid (edge (x, n) costs |x - n| mm; so |x - p| <= d26(x, p), equal along
//                axes and along 2-D/3-D diagonals). Computed exactly by two raster sweeps (see
//                lipschitzExtension). Then s = min(s, U) and s is clamped to
//                [min_size, max_size] (each when given).
//   With no interface sample at all (one material everywhere) s = U everywhere, then clamped.
//   U = max_size when given, otherwise the longest side of the materials' box (mm).
//
// What holds exactly (up to float rounding, relative 1e-6):
//   - s(x) <= s(n) + lipschitz * |x - n| for every pair of 26-neighbours x, n (the min with U
//     and the clamps keep this);
//   - s(p) <= lfs(p) at every interface sample p (before the clamps);
//   - min_size <= s <= max_size everywhere (when given; exact, the clamp is the last step).
// Memory: about 12 bytes per sample at the peak (material index, feature index, output), plus
// about 100 bytes per interface sample (sampled material values, point, normal) and 80 per medial
// sample; e.g. 51 MB peak for the 97^3 head phantom (32 MB above the input).
#include <array>
#include <cstdint>
#include <vector>

#include "Algorithms/Cleaving/Materials.h"
#include "Algorithms/Core/Progress.h"
#include "Algorithms/Core/Report.h"
#include "Algorithms/Core/Volume.h"

namespace tetflow {

struct SizingFieldParams {
  double sampling_rate = 1.0;   // samples per materials' voxel along each axis, > 0 (0.5 = every
                                // other voxel, 2 = twice as fine)
  double lipschitz = 0.2;       // largest growth of the size per mm of distance (mm/mm), > 0
  double feature_scaling = 1.0; // multiplies the local feature size, > 0
  int padding = 0;              // whole samples added around the grid on every side, >= 0
  double min_size = 0.0;        // mm, lower clamp of the field; 0 = none
  double max_size = 0.0;        // mm, upper clamp of the field; 0 = none (min_size <= max_size)
};

struct SizingFieldResult {
  ScalarVolume field;             // mm, on sizingGrid(materials.grid(), rate, padding)
  int64_t samples = 0;            // field.grid.voxelCount()
  int materialsPresent = 0;       // materials dominant at >= 1 sample
  int64_t interfaceEdges = 0;     // 6-neighbour pairs with different dominant materials
  int64_t interfaceSamples = 0;   // endpoints of interface edges
  int64_t medialSamples = 0;      // samples keeping a medial point
  double unboundedSize = 0.0;     // U (mm): max_size, or the longest side of the materials' box
  double minFeatureSize = 0.0;    // mm, over interface samples: lfs * feature_scaling (capped at
  double maxFeatureSize = 0.0;    //     U, before clamps); 0 when there is no interface
  double minSize = 0.0, maxSize = 0.0, meanSize = 0.0; // mm, over all samples, final field
  int64_t clampedToMin = 0;       // samples raised to min_size
  int64_t clampedToMax = 0;       // samples lowered to max_size (max_size given and exceeded)
};

// Throws InputError naming the parameter (and its allowed range) for bad parameters or a sampling
// grid of more than 2^31 - 1 samples; Cancelled when the progress sink asks to stop.
SizingFieldResult computeSizingField(const MaterialSet& materials, const SizingFieldParams& params,
                                     Progress& progress);

// Figures for a module Report (dims, spacing, counts, sizes in mm).
void writeSizingFieldReport(const SizingFieldResult& r, Report& report);

// ---- building blocks (exposed for tests) ----

// The sampling grid described above. InputError for sampling_rate <= 0 / not finite or
// padding < 0 (the message names the parameter).
GridGeometry sizingGrid(const GridGeometry& materialsGrid, double samplingRate, int padding);

// Exact Euclidean feature transform on a grid of `dims` with `spacing` (mm per axis).
// `seeds` lists seed samples by grid coordinates (i, j, k); on entry ft[x] must be the seed id
// (index into `seeds`) at each seed sample and -1 elsewhere (size dims[0]*dims[1]*dims[2]). On
// return ft[x] is the id of a seed nearest to x (ties: any of the nearest), or -1 everywhere when
// there is no seed. Parallel over grid lines; O(samples) time, no memory beyond per-thread lines.
void euclideanFeatureTransform(const std::array<int64_t, 3>& dims, const Vec3& spacing,
                               const std::vector<std::array<int32_t, 3>>& seeds,
                               std::vector<int32_t>& ft);

// In place: v(x) <- min over samples y of ( v0(y) + lipschitz * d26(x, y) ), d26 as above (v0 may
// hold +infinity for "no value"). Two raster sweeps (forward over the 13 neighbours earlier in
// index order, then backward over the 13 later ones) give exactly the shortest-path result: a
// shortest 26-neighbour path can always be made monotone in every coordinate (two steps with
// opposite signs along an axis are replaced by the same steps without that component, no
// longer), so it stays in the grid's box and can be reordered into the forward steps followed by
// the backward steps. Afterwards v(x) <= v(n) + lipschitz |x - n| for every 26-neighbour n.
void lipschitzExtension(const std::array<int64_t, 3>& dims, const Vec3& spacing, double lipschitz,
                        std::vector<float>& v);

} // namespace tetflow
