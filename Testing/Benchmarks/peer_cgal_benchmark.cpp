// Peer benchmark (issue 26 item 3): TetFlow's default pipeline against CGAL's Mesh_3 on the same
// label volumes, both judged by the project's mesh certificate (Algorithms/Quality/Certificate.h)
// and EvaluateQuality's dihedral angles.
//
// Inputs (each loaded or generated inside the child process that meshes it):
//   phantom   the head phantom of the default net (97^3 voxels of 2 mm; air stripped by TetFlow,
//             not meshed by CGAL);
//   spheres   Cleaver's spheres1..4 (28^3 float indicator functions, spacing 1): TetFlow cleaves
//             the functions as Nets/spheres.srn does; CGAL meshes their argmax labels, which is
//             also what the certificate compares both meshes with;
//   head      the layered head, by default the committed 2 mm copy
//             Testing/Data/layered_head_2mm.nii.gz (variant 0, read by the project's NIfTI reader);
//             with --head1mm the 1 mm head of Testing/Fixtures/LayeredHead.h (variant 0, needs
//             Debian's mricron-data, skipped with a message when absent), generated once in a child
//             into a temporary NRRD. The 2 mm copy is the default because CGAL at TetFlow's size on
//             the 1 mm head (4.4 M tets) takes over three minutes a run on two shared cores.
//
// TetFlow: what the shipped nets run, at their defaults (as fidelity_benchmark's "after" rows): a
// regular BCC lattice refined at thin layers (EdgeTopology, separating), cleavePipeline (repair,
// exterior of label 0 stripped with cavities kept, volume correction), improveMesh, finishLabels.
// Cell size per input: 4 mm for the phantom and the head (Nets/default.srn), 1 mm for the spheres
// (Nets/spheres.srn).
//
// CGAL: CGAL::Image_3 built in memory from the label volume (uint8, same spacing; voxel centres
// at the same physical places), padded with one voxel of 0 on every side so that CGAL's domain
// ends at the voxel box's faces as TetFlow's does (CGAL interpolates labels between voxel centres
// and is "outside" beyond the outermost centres). Label 0 is CGAL's outside: the air that reaches
// the box is not meshed, as TetFlow strips it; enclosed air (cavities, 26-connected components of
// label 0 not touching the box) gets a spare label so that CGAL meshes it like TetFlow keeps it,
// and is mapped back to 0 in the mesh. Labeled_mesh_domain_3::create_labeled_image_mesh_domain,
// Mesh_criteria_3 with facet_angle 25, cell_radius_edge_ratio 3 and one size h:
// facet_size = cell_size = h, facet_distance = h / 4; make_mesh_3 with CGAL's defaults
// (perturb and exude, each limited to the refinement's time; no ODT, no Lloyd); sequential
// (no CGAL_CONCURRENT_MESH_3 / TBB). The complex's cells become a TetMesh (material = subdomain
// index), every tet positively oriented.
//   matched size      h searched (log-log secant on the tet count) until CGAL's tets are within
//                     +-25 % of TetFlow's on the same input;
//   matched fidelity  from there, h kept and facet_distance halved per step until CGAL's worst
//                     per-label volume error is <= TetFlow's (fidelity-reached), or within 0.2
//                     points of the worst error of CGAL's labelled image function itself
//                     (fidelity-floor: finer meshes of that domain come no closer; each input's
//                     header line gives that function's per-label error, from 8 jittered samples
//                     per voxel), or the time is up (fidelity-time: a step is started only when
//                     twice the previous run fits in --fidelity-budget seconds per input, default
//                     180; any run is killed after --cap seconds, default 300). The last finished
//                     step is reported.
//
// Measured per (input, tool): wall time of the meshing (from the label volume in memory to the
// TetMesh in memory: TetFlow background + cleave + repair + strip + correction + improvement;
// CGAL image + domain + make_mesh_3 + export), peak memory of the meshing (each run is a forked
// child; after loading its input it resets the kernel's peak-RSS counter through
// /proc/self/clear_refs and reads VmHWM when the mesh is made, so the figure includes the input
// held in memory, whose RSS is printed as input_MB; without clear_refs: the child's ru_maxrss,
// marked *), tets, dihedral range and tets below 10 degrees, and from certifyMesh: worst
// per-label relative volume error (over the compared labels) and its label, voxel agreement,
// components lost / split / merged / spurious, spurious contact area.
//
//   peer_cgal_benchmark [RESULTS_FILE] [--inputs phantom,spheres,head] [--head1mm] [--quick]
//                       [--no-fidelity] [--cap SECONDS] [--fidelity-budget SECONDS] [--try H[:RATIO]]...
// (--try: only CGAL runs with facet_size = cell_size = H, facet_distance = RATIO * H, for experiments)
#include <fcntl.h>
#include <omp.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Image_3.h>
#include <CGAL/Labeled_mesh_domain_3.h>
#include <CGAL/Mesh_complex_3_in_triangulation_3.h>
#include <CGAL/Mesh_criteria_3.h>
#include <CGAL/Mesh_triangulation_3.h>
#include <CGAL/make_mesh_3.h>
#include <CGAL/version.h>

#include "Algorithms/BackgroundMesh/OctreeBcc.h"
#include "Algorithms/BackgroundMesh/ThinLayers.h"
#include "Algorithms/Cleaving/CleavePipeline.h"
#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/RawVolume.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Algorithms/MeshImprovement/MeshImprovement.h"
#include "Algorithms/Quality/Certificate.h"
#include "Algorithms/Quality/MeshQuality.h"
#include "Fixtures/LayeredHead.h"

using namespace tetflow;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

// ------------------------------------------------------------------------------------------------
// One run's figures: plain data, written by the child through a pipe.
struct Row {
  int ok = 0;            // 1 when the child finished
  char error[240] = {};  // why not
  double seconds = 0.0;  // meshing wall time
  double peakMB = 0.0;   // peak RSS of the meshing (see the header)
  double inputMB = 0.0;  // RSS when the meshing started (the input held in memory)
  int peakFromHwm = 0;   // 1: VmHWM after a reset; 0: ru_maxrss of the whole child
  int64_t tets = 0;
  int64_t below10 = 0;
  int valid = 0;
  double minDihedral = 0.0, maxDihedral = 0.0;
  double meshVolume = 0.0; // mm^3
  double worst = 0.0;      // relative
  int32_t worstLabel = 0;
  double agreement = 0.0;
  int lost = 0, split = 0, merged = 0, spurious = 0;
  double spuriousContact = 0.0; // mm^2
  char note[480] = {};          // free text (the domain check)
};

// /proc/self/status field in kB (VmHWM, VmRSS), -1 when absent.
double statusKb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  const size_t n = std::strlen(key);
  while (std::getline(f, line))
    if (line.compare(0, n, key) == 0 && line.size() > n && line[n] == ':') return std::atof(line.c_str() + n + 1);
  return -1.0;
}

// Resets VmHWM to the current RSS (Linux >= 4.0). False when not permitted.
bool resetPeakRss() {
  const int fd = ::open("/proc/self/clear_refs", O_WRONLY);
  if (fd < 0) return false;
  const bool ok = ::write(fd, "5", 1) == 1;
  ::close(fd);
  return ok;
}

// Runs f in a forked child; kills it after capSeconds (0 = no cap). The parent keeps nothing but
// the Row. peakFromHwm == 0 rows get the child's ru_maxrss.
Row inChild(const std::function<Row()>& f, double capSeconds, bool* timedOut = nullptr) {
  if (timedOut) *timedOut = false;
  int fds[2];
  if (::pipe(fds) != 0) {
    Row r;
    std::snprintf(r.error, sizeof r.error, "pipe failed");
    return r;
  }
  std::cout.flush();
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    Row r;
    try {
      r = f();
      r.ok = 1;
    } catch (const std::exception& e) {
      std::snprintf(r.error, sizeof r.error, "%s", e.what());
    }
    // Smaller than PIPE_BUF: one atomic write that does not block.
    if (::write(fds[1], &r, sizeof r) != static_cast<ssize_t>(sizeof r)) ::_exit(2);
    ::_exit(0);
  }
  ::close(fds[1]);
  Row r;
  if (pid < 0) {
    ::close(fds[0]);
    std::snprintf(r.error, sizeof r.error, "fork failed");
    return r;
  }
  const double t0 = now();
  int status = 0;
  struct rusage ru {};
  for (;;) {
    const pid_t w = ::wait4(pid, &status, WNOHANG, &ru);
    if (w == pid) break;
    if (capSeconds > 0 && now() - t0 > capSeconds) {
      ::kill(pid, SIGKILL);
      ::wait4(pid, &status, 0, &ru);
      if (timedOut) *timedOut = true;
      break;
    }
    ::usleep(20000);
  }
  const ssize_t got = ::read(fds[0], &r, sizeof r);
  ::close(fds[0]);
  if (got != static_cast<ssize_t>(sizeof r)) {
    r = Row();
    if (timedOut && *timedOut)
      std::snprintf(r.error, sizeof r.error, "killed after %.0f s (cap)", capSeconds);
    else
      std::snprintf(r.error, sizeof r.error, "child ended without a result (status %d)", status);
  }
  if (r.ok && !r.peakFromHwm) r.peakMB = double(ru.ru_maxrss) / 1024.0;
  return r;
}

// ------------------------------------------------------------------------------------------------
// Inputs.

struct Input {
  LabelVolume labels;                   // what the certificate compares with (argmax for spheres)
  std::unique_ptr<MaterialSet> mats;    // TetFlow's materials (null for CGAL runs)
  std::optional<int32_t> strip;         // TetFlow's strip_exterior
  double cell = 4.0;                    // TetFlow's lattice cell (mm)
};

struct InputSpec {
  std::string name;     // column 1
  std::string kind;     // phantom, spheres, file
  std::string path;     // kind file: a label volume written by prepare
  std::string describe; // the header line
  double cell = 4.0;
  bool strip = true;
};

Input loadInput(const InputSpec& s, bool withMaterials) {
  Input in;
  in.cell = s.cell;
  if (s.strip) in.strip = 0;
  if (s.kind == "phantom") {
    in.labels = makePhantom(PhantomParams{}).volume;
  } else if (s.kind == "spheres") {
    std::vector<ScalarVolume> vols;
    for (int i = 1; i <= 4; ++i)
      vols.push_back(readScalarVolume(std::string(TETFLOW_TEST_DATA) + "/spheres" + std::to_string(i) + ".nrrd"));
    auto ind = std::make_unique<IndicatorMaterials>(std::move(vols), std::vector<int32_t>{1, 2, 3, 4});
    in.labels = ind->dominantLabels();
    if (withMaterials) in.mats = std::move(ind);
    return in;
  } else {
    in.labels = readLabelVolume(s.path);
  }
  if (withMaterials) in.mats = std::make_unique<LabelMaterials>(std::make_shared<const LabelVolume>(in.labels), kDefaultBlendSigma);
  return in;
}

// ------------------------------------------------------------------------------------------------
// Judging a mesh (after the peak was read).

void judge(const TetMesh& mesh, const LabelVolume& labels, Row& r) {
  NullProgress np;
  const CertificateResult c = certifyMesh(mesh, labels, np);
  const QualityResult q = evaluateQuality(mesh, QualityParams{}, np);
  r.tets = static_cast<int64_t>(mesh.numTets());
  r.below10 = q.tetsBelow[1];
  r.valid = q.valid ? 1 : 0;
  r.minDihedral = q.minDihedral;
  r.maxDihedral = q.maxDihedral;
  r.meshVolume = q.volume;
  r.worst = 0.0;
  r.worstLabel = -1;
  for (const auto& lc : c.labels) {
    if (lc.excluded) continue;
    if (std::abs(lc.relError) > std::abs(r.worst) || r.worstLabel < 0) {
      r.worst = lc.relError;
      r.worstLabel = lc.label;
    }
  }
  r.agreement = c.agreement;
  r.lost = c.lost;
  r.split = c.split;
  r.merged = c.merged;
  r.spurious = c.spurious;
  r.spuriousContact = c.spuriousContactArea;
}

void startMeasuring(Row& r) {
  r.peakFromHwm = resetPeakRss() ? 1 : 0;
  r.inputMB = statusKb("VmRSS") / 1024.0;
}

void stopMeasuring(Row& r) {
  if (r.peakFromHwm) r.peakMB = statusKb("VmHWM") / 1024.0;
}

// ------------------------------------------------------------------------------------------------
// TetFlow: the default net's pipeline (fidelity_benchmark's runOne, "after", regular lattice).

Row runTetFlow(const InputSpec& spec) {
  Input in = loadInput(spec, true);
  Row r;
  NullProgress np;
  startMeasuring(r);
  const double t0 = now();
  const EdgeTopology thin(in.labels, EdgeTopology::Mode::Separating);
  const BackgroundMesh bg = generateThinLayerBcc(in.labels.grid, BccParams{in.cell, 0.0}, OctreeBccParams{}, thin, np).background;
  CleavePipelineParams pp;
  pp.strip = in.strip;
  const ImproveParams ip;
  pp.correction.min_angle = ip.min_angle; // as CleaveMesh: the improvement's bounds
  pp.correction.max_angle = ip.max_angle;
  CleavePipelineResult res = cleavePipeline(bg, *in.mats, pp, np);
  improveMesh(res.cleaved.mesh, ip, np, &res.faceNeighbours);
  finishLabels(res.cleaved.mesh, *in.mats, res, np);
  r.seconds = now() - t0;
  stopMeasuring(r);
  judge(res.cleaved.mesh, in.labels, r);
  return r;
}

// ------------------------------------------------------------------------------------------------
// CGAL Mesh_3.

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Domain = CGAL::Labeled_mesh_domain_3<Kernel>;
using Tr = CGAL::Mesh_triangulation_3<Domain, CGAL::Default, CGAL::Sequential_tag>::type;
using C3t3 = CGAL::Mesh_complex_3_in_triangulation_3<Tr>;
using Criteria = CGAL::Mesh_criteria_3<Tr>;

struct CgalSettings {
  double h = 4.0;              // facet_size = cell_size (mm)
  double distanceRatio = 0.25; // facet_distance = ratio * h
  double facetAngle = 25.0;
  double radiusEdge = 3.0;
  bool perturb = true, exude = true, odt = false, lloyd = false;
  std::string describe() const {
    char b[200];
    std::snprintf(b, sizeof b, "h=%.3g: facet_size=cell_size=%.3g facet_distance=%.3g angle=%g ratio=%g%s%s%s%s", h, h,
                  distanceRatio * h, facetAngle, radiusEdge, perturb ? " perturb" : "", exude ? " exude" : "",
                  odt ? " odt" : "", lloyd ? " lloyd" : "");
    return b;
  }
};

// The label image CGAL meshes: uint8, one voxel of 0 around, cavities (label 0 not reaching the
// box, 26-connected) relabelled `cavity`. Returns the image; *cavity gets the spare label.
CGAL::Image_3 cgalImage(const LabelVolume& v, int* cavity) {
  const GridGeometry& g = v.grid;
  if (!g.isAxisAligned()) throw InputError("peer_cgal_benchmark: CGAL::Image_3 needs axis-aligned voxels");
  int32_t maxLabel = 0;
  for (int32_t x : v.data) {
    if (x < 0) throw InputError("peer_cgal_benchmark: negative labels do not fit a uint8 image");
    maxLabel = std::max(maxLabel, x);
  }
  if (maxLabel >= 255) throw InputError("peer_cgal_benchmark: labels above 254 do not fit a uint8 image");
  *cavity = maxLabel + 1;
  const int64_t nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  // Air reaching the box: flood fill from the box's label-0 voxels.
  std::vector<uint8_t> outside(v.data.size(), 0);
  std::deque<int64_t> queue;
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        const bool onBox = i == 0 || j == 0 || k == 0 || i == nx - 1 || j == ny - 1 || k == nz - 1;
        const int64_t id = v.index(i, j, k);
        if (onBox && v.data[size_t(id)] == 0) {
          outside[size_t(id)] = 1;
          queue.push_back(id);
        }
      }
  while (!queue.empty()) {
    const int64_t id = queue.front();
    queue.pop_front();
    const int64_t i = id % nx, j = (id / nx) % ny, k = id / (nx * ny);
    for (int64_t dk = -1; dk <= 1; ++dk)
      for (int64_t dj = -1; dj <= 1; ++dj)
        for (int64_t di = -1; di <= 1; ++di) {
          const int64_t a = i + di, b = j + dj, c = k + dk;
          if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz) continue;
          const int64_t n = v.index(a, b, c);
          if (outside[size_t(n)] || v.data[size_t(n)] != 0) continue;
          outside[size_t(n)] = 1;
          queue.push_back(n);
        }
  }
  _image* im = ::_createImage(size_t(nx + 2), size_t(ny + 2), size_t(nz + 2), 1, g.spacing[0], g.spacing[1],
                              g.spacing[2], 1, WK_FIXED, SGN_UNSIGNED);
  if (!im || !im->data) throw InputError("peer_cgal_benchmark: _createImage failed");
  // Voxel (i, j, k) of the padded image sits at t + (i, j, k) * spacing: the input's voxel 0 at origin.
  im->tx = static_cast<float>(g.origin[0] - g.spacing[0]);
  im->ty = static_cast<float>(g.origin[1] - g.spacing[1]);
  im->tz = static_cast<float>(g.origin[2] - g.spacing[2]);
  auto* d = static_cast<unsigned char*>(im->data);
  std::fill(d, d + (nx + 2) * (ny + 2) * (nz + 2), static_cast<unsigned char>(0));
  for (int64_t k = 0; k < nz; ++k)
    for (int64_t j = 0; j < ny; ++j)
      for (int64_t i = 0; i < nx; ++i) {
        const int64_t id = v.index(i, j, k);
        const int32_t l = v.data[size_t(id)];
        d[(i + 1) + (nx + 2) * ((j + 1) + (ny + 2) * (k + 1))] =
            static_cast<unsigned char>(l == 0 && !outside[size_t(id)] ? *cavity : l);
      }
  return CGAL::Image_3(im);
}

TetMesh meshWithCgal(const LabelVolume& v, const CgalSettings& s) {
  int cavity = 0;
  const CGAL::Image_3 image = cgalImage(v, &cavity);
  CGAL::Random rng(0);
  namespace P = CGAL::parameters;
  const Domain domain = Domain::create_labeled_image_mesh_domain(image, P::p_rng = &rng);
  const Criteria criteria(P::facet_angle = s.facetAngle, P::facet_size = s.h, P::facet_distance = s.distanceRatio * s.h,
                          P::cell_radius_edge_ratio = s.radiusEdge, P::cell_size = s.h);
  const C3t3 c3t3 = CGAL::make_mesh_3<C3t3>(domain, criteria, s.perturb ? P::perturb() : P::no_perturb(),
                                            s.exude ? P::exude() : P::no_exude(), s.odt ? P::odt() : P::no_odt(),
                                            s.lloyd ? P::lloyd() : P::no_lloyd());
  // Export: the complex's cells, their vertices numbered in order of first use.
  TetMesh m;
  const Tr& tr = c3t3.triangulation();
  const auto point = tr.geom_traits().construct_point_3_object();
  std::unordered_map<const void*, int32_t> index;
  index.reserve(size_t(c3t3.number_of_cells_in_complex()));
  m.tets.reserve(size_t(c3t3.number_of_cells_in_complex()));
  for (auto c = c3t3.cells_in_complex_begin(); c != c3t3.cells_in_complex_end(); ++c) {
    TetMesh::Tet t{};
    for (int i = 0; i < 4; ++i) {
      const auto vh = c->vertex(i);
      const auto [it, inserted] = index.emplace(&*vh, static_cast<int32_t>(m.points.size()));
      if (inserted) {
        const auto p = point(tr.point(vh));
        m.points.push_back({CGAL::to_double(p.x()), CGAL::to_double(p.y()), CGAL::to_double(p.z())});
      }
      t[size_t(i)] = it->second;
    }
    if (signedTetVolume(m.points[size_t(t[0])], m.points[size_t(t[1])], m.points[size_t(t[2])], m.points[size_t(t[3])]) < 0)
      std::swap(t[0], t[1]);
    m.tets.push_back(t);
    const int sub = static_cast<int>(c3t3.subdomain_index(c));
    m.materials.push_back(sub == cavity ? 0 : sub);
  }
  return m;
}

Row runCgal(const InputSpec& spec, const CgalSettings& s) {
  Input in = loadInput(spec, false);
  Row r;
  startMeasuring(r);
  const double t0 = now();
  const TetMesh m = meshWithCgal(in.labels, s);
  r.seconds = now() - t0;
  stopMeasuring(r);
  if (m.numTets() == 0) throw InputError("CGAL produced no tets");
  judge(m, in.labels, r);
  return r;
}

// How far CGAL's labelled image function itself (Image_3::labellized_trilinear_interpolation: the
// label of largest trilinear weight) is from the voxels, per label: 8 jittered samples per voxel
// (one per octant, fixed seed) against the voxel counts. A mesh of that domain cannot do better
// than this, however fine.
Row cgalDomainCheck(const InputSpec& spec) {
  const Input in = loadInput(spec, false);
  int cavity = 0;
  const CGAL::Image_3 image = cgalImage(in.labels, &cavity);
  const auto* d = static_cast<const unsigned char*>(image.data());
  const size_t nx = image.xdim(), ny = image.ydim(), nz = image.zdim();
  std::array<double, 256> voxels{}, samples{};
  for (size_t i = 0; i < nx * ny * nz; ++i) voxels[d[i]] += 1.0;
  std::mt19937 rng(26);
  std::uniform_real_distribution<double> jitter(-0.25, 0.25);
  const double vx = image.vx(), vy = image.vy(), vz = image.vz();
  for (size_t k = 1; k + 1 < nz; ++k)
    for (size_t j = 1; j + 1 < ny; ++j)
      for (size_t i = 1; i + 1 < nx; ++i)
        for (int o = 0; o < 8; ++o) {
          const double x = (double(i) + ((o & 1) ? 0.25 : -0.25) + jitter(rng)) * vx;
          const double y = (double(j) + ((o & 2) ? 0.25 : -0.25) + jitter(rng)) * vy;
          const double z = (double(k) + ((o & 4) ? 0.25 : -0.25) + jitter(rng)) * vz;
          samples[image.labellized_trilinear_interpolation<unsigned char>(x, y, z, static_cast<unsigned char>(0))] += 0.125;
        }
  Row r;
  std::string note;
  double worst = 0.0;
  int worstLabel = -1;
  for (int l = 1; l < 256; ++l) {
    if (voxels[size_t(l)] == 0.0 && samples[size_t(l)] == 0.0) continue;
    const double rel = voxels[size_t(l)] > 0 ? samples[size_t(l)] / voxels[size_t(l)] - 1.0 : 1.0;
    char b[48];
    std::snprintf(b, sizeof b, "%sL%d %+.2f%%", note.empty() ? "" : " ", l == cavity ? 0 : l, 100.0 * rel);
    note += b;
    if (std::abs(rel) > std::abs(worst)) {
      worst = rel;
      worstLabel = l == cavity ? 0 : l;
    }
  }
  char b[64];
  std::snprintf(b, sizeof b, "; worst %+.2f%% (L%d)", 100.0 * worst, worstLabel);
  note += b;
  r.worst = worst;
  r.worstLabel = worstLabel;
  std::snprintf(r.note, sizeof r.note, "%s", note.c_str());
  return r;
}

// ------------------------------------------------------------------------------------------------
// Output.

const char* kHeader =
    "# input     tool     match             wall_s  peak_MB input_MB       tets  dihedral_deg    <10deg "
    "worst_vol_err (label)  agree  lost split merged spur spur_contact_mm2  criteria\n";

std::string line(const std::string& input, const std::string& tool, const std::string& match, const Row& r,
                 const std::string& criteria) {
  char buf[768];
  if (!r.ok) {
    std::snprintf(buf, sizeof buf, "%-11s %-8s %-16s  failed: %s  [%s]\n", input.c_str(), tool.c_str(), match.c_str(),
                  r.error, criteria.c_str());
    return buf;
  }
  std::snprintf(buf, sizeof buf,
                "%-11s %-8s %-16s %7.1f %8.0f%s %7.0f %10lld  [%5.1f, %5.1f] %7lld  %+9.2f%% (L%-3d)  %6.3f %5d %5d %6d %4d "
                "%16.1f  %s%s\n",
                input.c_str(), tool.c_str(), match.c_str(), r.seconds, r.peakMB, r.peakFromHwm ? " " : "*", r.inputMB,
                static_cast<long long>(r.tets), r.minDihedral, r.maxDihedral, static_cast<long long>(r.below10),
                100.0 * r.worst, r.worstLabel, r.agreement, r.lost, r.split, r.merged, r.spurious, r.spuriousContact,
                criteria.c_str(), r.valid ? "" : " (INVALID mesh per EvaluateQuality)");
  return buf;
}

std::string cpuModel() {
  std::ifstream f("/proc/cpuinfo");
  std::string l;
  while (std::getline(f, l))
    if (l.rfind("model name", 0) == 0) {
      const size_t c = l.find(':');
      return c == std::string::npos ? l : l.substr(c + 2);
    }
  return "unknown CPU";
}

std::string loadAverage() {
  std::ifstream f("/proc/loadavg");
  double a = 0, b = 0, c = 0;
  f >> a >> b >> c;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f %.2f %.2f", a, b, c);
  return buf;
}

} // namespace

int main(int argc, char** argv) {
  std::string results = "peer_cgal_results.txt";
  std::string inputs = "phantom,spheres,head";
  bool head2mm = true, fidelity = true;
  double cap = 300.0, fidelityBudget = 180.0;
  std::vector<CgalSettings> tries; // --try H:RATIO (experiments: only these CGAL runs)
  for (int a = 1; a < argc; ++a) {
    const std::string s = argv[a];
    if (s == "--inputs" && a + 1 < argc) inputs = argv[++a];
    else if (s == "--head1mm") head2mm = false;
    else if (s == "--quick") { inputs = "phantom"; fidelity = false; }
    else if (s == "--no-fidelity") fidelity = false;
    else if (s == "--cap" && a + 1 < argc) cap = std::atof(argv[++a]);
    else if (s == "--fidelity-budget" && a + 1 < argc) fidelityBudget = std::atof(argv[++a]);
    else if (s == "--try" && a + 1 < argc) {
      CgalSettings t;
      const std::string v = argv[++a];
      t.h = std::atof(v.c_str());
      if (v.find(':') != std::string::npos) t.distanceRatio = std::atof(v.c_str() + v.find(':') + 1);
      tries.push_back(t);
    }
    else if (!s.empty() && s[0] == '-') {
      std::cerr << "usage: peer_cgal_benchmark [RESULTS_FILE] [--inputs phantom,spheres,head] [--head1mm] [--quick] "
                   "[--no-fidelity] [--cap SECONDS] [--fidelity-budget SECONDS] [--try H[:RATIO]]...\n";
      return 2;
    } else results = s;
  }
  const double started = now();
  std::ostringstream out;
  auto emit = [&](const std::string& s) {
    out << s;
    std::cout << s << std::flush;
  };
  {
    char date[64];
    const std::time_t t = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M %Z", std::localtime(&t));
    // omp_get_max_threads() only reads the ICVs; no OpenMP thread is started in the parent.
    emit(std::string("# peer_cgal_benchmark, ") + date + ", " + cpuModel() + ", " +
         std::to_string(std::thread::hardware_concurrency()) + " hardware threads, load average at start " +
         loadAverage() + "\n");
    emit(std::string("# TetFlow: default pipeline (thin-layer BCC, cleave, repair, strip 0 keeping cavities, volume "
                     "correction, improvement), OpenMP ") +
         std::to_string(omp_get_max_threads()) + " threads.\n");
    emit(std::string("# CGAL ") + CGAL_VERSION_STR +
         " Mesh_3 (Debian libcgal-dev), sequential (no CGAL_CONCURRENT_MESH_3/TBB): labeled image domain "
         "(uint8 Image_3 in memory, padded by one voxel of 0, cavities meshed), Mesh_criteria_3 facet_angle 25, "
         "cell_radius_edge_ratio 3, facet_size = cell_size = h, facet_distance = h/4; make_mesh_3 defaults "
         "(perturb + exude, each time-limited to the refinement time; no ODT/Lloyd).\n");
    emit("# match: 'size' = h searched until CGAL's tets are within +-25 % of TetFlow's ('size>25%' when 5 tries did "
         "not get there: the closest); 'fidelity-*' = from there facet_distance halved per step (h kept) until CGAL's "
         "worst |volume error| <= TetFlow's (-reached), or within 0.2 points of the worst error of CGAL's labelled "
         "image function itself (-floor), or out of time (-time: a step starts only when twice the previous run "
         "fits in the " + std::to_string(int(fidelityBudget)) + " s per input; any run is killed after " +
         std::to_string(int(cap)) + " s). '#  ... search' lines are the steps.\n");
    emit("# wall_s: label volume in memory -> TetMesh in memory. peak_MB: VmHWM of the child that meshes, reset after "
         "loading the input (input_MB = RSS then, included in the peak); '*' = ru_maxrss of the whole child. "
         "worst_vol_err: largest |relative error| over the labels the certificate compares (label 0 = cavities "
         "when the exterior is stripped; excluded when it has no tets). Certificate and angles by the project's "
         "certifyMesh / evaluateQuality for both tools.\n");
  }

  // Temporary files (the layered head generated once).
  char tmpl[] = "/tmp/peer_cgal_XXXXXX";
  const char* tmpdir = ::mkdtemp(tmpl);
  if (!tmpdir) {
    std::cerr << "mkdtemp failed\n";
    return 1;
  }

  std::vector<InputSpec> specs;
  auto wanted = [&](const std::string& n) { return ("," + inputs + ",").find("," + n + ",") != std::string::npos; };
  if (wanted("phantom"))
    specs.push_back({"phantom", "phantom", "", "head phantom 97^3 voxels of 2 mm (1 scalp, 2 skull, 3 CSF one voxel, "
                                               "4 brain; air 0 outside), TetFlow cell 4 mm (Nets/default.srn)",
                     4.0, true});
  if (wanted("spheres"))
    specs.push_back({"spheres", "spheres", "", "spheres1..4, 28^3 indicator functions of 1 mm (labels 1-4 fill the "
                                               "box, nothing stripped), TetFlow cell 1 mm (Nets/spheres.srn); CGAL "
                                               "and the certificate use their argmax labels",
                     1.0, false});
  if (wanted("head")) {
    InputSpec h;
    h.name = head2mm ? "head_2mm" : "head_1mm";
    h.kind = "file";
    h.cell = 4.0;
    std::string why;
    if (head2mm) {
      h.path = std::string(TETFLOW_TEST_DATA) + "/layered_head_2mm.nii.gz";
      h.describe = "layered head 2 mm (Testing/Data/layered_head_2mm.nii.gz, 91 x 109 x 91; 0 air outside and "
                   "cavities, 1 scalp, 2 skull, 3 CSF, 4 grey, 5 white), TetFlow cell 4 mm";
      specs.push_back(h);
    } else if (mricronAtlasesPresent(mricronTemplatesDir(), &why)) {
      h.path = std::string(tmpdir) + "/layered_head_1mm.nrrd";
      h.describe = "layered head 1 mm (Testing/Fixtures/LayeredHead.h variant 0, 182 x 218 x 182; 0 air outside and "
                   "cavities, 1 scalp, 2 skull, 3 CSF, 4 grey, 5 white), TetFlow cell 4 mm";
      const std::string path = h.path;
      const Row g = inChild(
          [&]() {
            writeVolume(path, fromLabelVolume(makeLayeredHead(mricronTemplatesDir(), LayeredHeadParams{}), VoxelType::UInt8));
            return Row();
          },
          0.0);
      if (g.ok) specs.push_back(h);
      else emit(std::string("layered head 1 mm: skipped (generation failed: ") + g.error + ")\n");
    } else {
      emit("layered head 1 mm: skipped (" + why + ")\n");
    }
  }

  for (const InputSpec& spec : specs) {
    emit(spec.name + ": " + spec.describe + "\n");
    const Row dc = inChild([&]() { return cgalDomainCheck(spec); }, 0.0);
    emit(std::string("# CGAL's labelled image function vs the voxels (8 jittered samples per voxel): ") +
         (dc.ok ? dc.note : dc.error) + "\n");
    emit(kHeader);
    if (!tries.empty()) {
      for (const CgalSettings& t : tries) {
        const Row c = inChild([&]() { return runCgal(spec, t); }, cap);
        emit(line(spec.name, "cgal", "try", c, t.describe()));
      }
      continue;
    }
    const Row tf = inChild([&]() { return runTetFlow(spec); }, 0.0);
    char crit[96];
    std::snprintf(crit, sizeof crit, "regular BCC cell %.3g mm, defaults", spec.cell);
    const std::string tfLine = line(spec.name, "tetflow", "-", tf, crit);
    emit(tfLine);
    if (!tf.ok || tf.tets == 0) continue;

    // Matched size: log-log secant on tets(h), starting from the mean tet volume TetFlow reached
    // (a CGAL tet of size bound h averages about 0.2 h^3 here).
    CgalSettings s;
    const double target = double(tf.tets);
    s.h = std::cbrt(tf.meshVolume / target / 0.2);
    std::vector<std::pair<double, double>> tried; // (log h, log tets)
    Row match;
    CgalSettings matched = s;
    bool found = false;
    for (int it = 0; it < 5 && !found; ++it) {
      bool timedOut = false;
      const Row c = inChild([&]() { return runCgal(spec, s); }, cap, &timedOut);
      const std::string l = line(spec.name, "cgal", "size search", c, s.describe());
      emit("#  " + l);
      if (!c.ok) {
        if (!timedOut) break;
        tried.emplace_back(std::log(s.h), std::log(target * 4.0)); // too many tets to finish: treat as 4x
      } else {
        tried.emplace_back(std::log(s.h), std::log(double(c.tets)));
        if (!match.ok || std::abs(std::log(double(c.tets) / target)) < std::abs(std::log(double(match.tets) / target))) {
          match = c; // the closest so far
          matched = s;
        }
        if (std::abs(double(c.tets) / target - 1.0) <= 0.25) {
          found = true;
          break;
        }
      }
      // Next h: slope from the last two tries, else -3 (tets ~ h^-3); clamped to [-4, -1.5].
      double slope = -3.0;
      if (tried.size() >= 2) {
        const auto& a = tried[tried.size() - 2];
        const auto& b = tried.back();
        if (std::abs(b.first - a.first) > 1e-9) slope = std::clamp((b.second - a.second) / (b.first - a.first), -4.0, -1.5);
      }
      s.h = std::exp(tried.back().first + (std::log(target) - tried.back().second) / slope);
    }
    const std::string ml = line(spec.name, "cgal", found ? "size" : "size>25%", match, matched.describe());
    emit(ml);
    if (!fidelity || !match.ok) continue;

    // Matched fidelity: facet_distance halved per step (h kept: the surface approximation is what
    // decides the volumes) until CGAL's worst |volume error| is TetFlow's or better (reached), or
    // within 0.2 points of the worst error of CGAL's labelled image function itself (the floor:
    // finer meshes of that domain get no closer), or the time is up.
    const double floorErr = dc.ok ? std::abs(dc.worst) : 0.0;
    // A step is started only when it is predicted to end within the budget: a finer step took
    // 1.5 to 1.8 times the previous one here, so twice the previous run.
    const double fStart = now();
    Row best = match;
    CgalSettings bestS = matched, f = matched;
    std::string outcome, skipped;
    int steps = 0;
    for (;;) {
      if (std::abs(best.worst) <= std::abs(tf.worst)) {
        outcome = "fidelity-reached";
        break;
      }
      if (dc.ok && std::abs(best.worst) <= floorErr + 0.002) {
        outcome = "fidelity-floor";
        break;
      }
      const double predicted = 2.0 * best.seconds;
      if (now() - fStart + predicted > fidelityBudget) {
        outcome = "fidelity-time";
        char b[200];
        std::snprintf(b, sizeof b, "next step (facet_distance %.3g) not started: predicted ~%.0f s, budget %.0f s",
                      0.5 * f.distanceRatio * f.h, predicted, fidelityBudget);
        skipped = b;
        break;
      }
      f.distanceRatio *= 0.5;
      bool timedOut = false;
      const Row c = inChild([&]() { return runCgal(spec, f); }, cap, &timedOut);
      emit("#  " + line(spec.name, "cgal", "fidelity search", c, f.describe()));
      if (!c.ok) {
        outcome = timedOut ? "fidelity-time" : "fidelity-failed";
        break;
      }
      ++steps;
      best = c;
      bestS = f;
    }
    if (steps == 0 && outcome != "fidelity-reached" && outcome != "fidelity-floor") {
      char b[400];
      std::snprintf(b, sizeof b, "%-11s %-8s %-16s  no finer run finished: %s; CGAL's labelled image function alone is "
                    "%+.2f%% (L%d) off, TetFlow %+.2f%%\n",
                    spec.name.c_str(), "cgal", outcome.c_str(), skipped.empty() ? "the run hit the cap" : skipped.c_str(),
                    100.0 * dc.worst, dc.worstLabel, 100.0 * tf.worst);
      emit(b);
    } else {
      emit(line(spec.name, "cgal", outcome, best, bestS.describe()));
    }
  }
  std::filesystem::remove_all(tmpdir);
  char tail[128];
  std::snprintf(tail, sizeof tail, "# total %.0f s\n", now() - started);
  emit(tail);
  std::ofstream(results) << out.str();
  return 0;
}
