#include "Meg.h"
#include "SourceModels.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <map>
#include <sstream>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Timing.h"
#include "Algorithms/Core/MemoryBudget.h"
#include "Algorithms/IO/FileUtil.h"
#include "Assembly.h"
#include "BoundaryConditions.h"
#include "LeadField.h"

namespace tetflow {

namespace {

bool parseFiniteNumber(const std::string& t, double& v) {
  if (t.empty()) return false;
  char* end = nullptr;
  v = std::strtod(t.c_str(), &end);
  return end == t.c_str() + t.size() && std::isfinite(v);
}

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> f;
  std::string cur;
  for (char ch : line) {
    if (ch == ',' || ch == ';' || ch == '\t' || ch == ' ' || ch == '\r' || ch == '\v' || ch == '\f') {
      if (!cur.empty()) f.push_back(cur), cur.clear();
    } else {
      cur.push_back(ch);
    }
  }
  if (!cur.empty()) f.push_back(cur);
  return f;
}

// sigma_T as a matrix, per label (the table's lookup is a map search).
struct SigmaLookup {
  std::map<int32_t, Mat3> byLabel;
  SigmaLookup(const TetMesh& mesh, const ConductivityTable& table) {
    for (int32_t l : presentMaterials(mesh)) byLabel[l] = tensorMatrix(table.tensor(l));
  }
  const Mat3& operator()(int32_t label) const { return byLabel.at(label); }
};

// Coils located inside the mesh (a bounding-box test first, then the tet search).
int64_t coilsInside(const TetMesh& mesh, const std::vector<MegSensor>& sensors) {
  Vec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3& p : mesh.points)
    for (int k = 0; k < 3; ++k) lo[size_t(k)] = std::min(lo[size_t(k)], p[size_t(k)]), hi[size_t(k)] = std::max(hi[size_t(k)], p[size_t(k)]);
  int64_t n = 0;
  const TetLocator locator(mesh);
  for (const MegSensor& s : sensors)
    for (const MegCoil& c : s.coils) {
      bool inBox = true;
      for (int k = 0; k < 3; ++k) inBox &= c.position[size_t(k)] >= lo[size_t(k)] && c.position[size_t(k)] <= hi[size_t(k)];
      if (inBox && locator.locate(c.position)) ++n;
    }
  return n;
}

void checkSensors(const std::vector<MegSensor>& sensors) {
  if (sensors.empty()) throw InputError("sensors: none given; the MEG needs at least one sensor");
  for (const MegSensor& s : sensors) {
    if (s.coils.empty()) throw InputError("sensor " + s.name + ": no coils");
    for (const MegCoil& c : s.coils) {
      const double n = norm(c.normal);
      if (!std::isfinite(n) || std::abs(n - 1.0) > 1e-9 || !std::isfinite(c.weight) ||
          !std::isfinite(c.position[0]) || !std::isfinite(c.position[1]) || !std::isfinite(c.position[2]))
        throw InputError("sensor " + s.name + ": a coil with a non-finite position or weight, or a normal "
                         "that is not a unit vector");
    }
  }
}

} // namespace

// ---------------------------------------------------------------------------------------------
// Sensor file

std::vector<MegSensor> readMegSensors(const std::string& path, double unitScale) {
  if (!std::isfinite(unitScale) || unitScale < 0)
    throw InputError(path + ": unit scale must be 0 (mm) or a positive factor to mm, not " + std::to_string(unitScale));
  const double scale = unitScale > 0 ? unitScale : 1.0;
  int64_t size = 0;
  const std::vector<char> bytes = readFilePrefix(path, size_t(64) << 20, &size);
  if (size > (int64_t(64) << 20)) throw InputError(path + ": over 64 MiB; a sensor file holds a few kB");
  std::string text(bytes.begin(), bytes.end());
  if (text.size() >= 3 && text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.erase(0, 3);

  std::vector<MegSensor> out;
  std::map<std::string, int> firstLine; // sensor name -> line of its first coil
  std::istringstream in(text);
  std::string line;
  int lineNo = 0;
  bool sawContent = false;
  while (std::getline(in, line)) {
    ++lineNo;
    const auto f = splitFields(line);
    if (f.empty() || f[0][0] == '#') continue;
    const std::string where = path + ", line " + std::to_string(lineNo) + ": ";
    if (!sawContent) {
      sawContent = true;
      bool anyNumber = false;
      double v;
      for (size_t i = 1; i < f.size() && i < 7; ++i) anyNumber |= parseFiniteNumber(f[i], v);
      if (!anyNumber && f.size() > 1) continue; // header
    }
    if (f.size() != 7 && f.size() != 8)
      throw InputError(where + "expected 7 or 8 fields 'name x y z nx ny nz [weight]', found " +
                       std::to_string(f.size()));
    for (unsigned char ch : f[0])
      if (ch < 0x20 || ch == 0x7f) throw InputError(where + "the sensor name holds a control character");
    double v[8] = {0, 0, 0, 0, 0, 0, 1, 0};
    static const char* what[7] = {"x", "y", "z", "nx", "ny", "nz", "weight"};
    for (size_t i = 1; i < f.size(); ++i)
      if (!parseFiniteNumber(f[i], v[i - 1]))
        throw InputError(where + what[i - 1] + " '" + f[i] + "' is not a finite number");
    MegCoil c;
    c.position = scale * Vec3{v[0], v[1], v[2]};
    if (!std::isfinite(c.position[0]) || !std::isfinite(c.position[1]) || !std::isfinite(c.position[2]))
      throw InputError(where + "the position is not finite after scaling");
    const Vec3 n{v[3], v[4], v[5]};
    const double len = norm(n);
    if (!(len > 0) || !std::isfinite(len))
      throw InputError(where + "the orientation (nx, ny, nz) is zero; give the coil's normal direction");
    c.normal = (1.0 / len) * n;
    c.weight = v[6];
    if (c.weight == 0) throw InputError(where + "the weight is 0; leave the coil out instead");
    c.line = lineNo;
    if (!out.empty() && out.back().name == f[0]) {
      out.back().coils.push_back(c);
    } else {
      auto it = firstLine.find(f[0]);
      if (it != firstLine.end())
        throw InputError(where + "sensor '" + f[0] + "' continues after other sensors (its first coil is on line " +
                         std::to_string(it->second) + "); put a sensor's coils on consecutive lines, or rename it");
      firstLine[f[0]] = lineNo;
      out.push_back(MegSensor{f[0], {c}});
    }
    if (lineNo > 2000000) throw InputError(path + ": more than 2 million lines");
  }
  if (out.empty()) throw InputError(path + ": no sensors (lines 'name x y z nx ny nz [weight]' in mm)");
  return out;
}

// ---------------------------------------------------------------------------------------------
// Closed forms

Vec3 megPrimaryField(const Vec3& r, const Vec3& r0, const Vec3& q) {
  const Vec3 d = r - r0;
  const double R = norm(d);
  return (kMegFemtoTesla / (R * R * R)) * cross(q, d);
}

Vec3 sarvasField(const Vec3& rIn, const Vec3& r0In, const Vec3& q, const Vec3& center) {
  const Vec3 r = rIn - center, r0 = r0In - center;
  const double rn = norm(r);
  if (!(rn > 0)) throw InputError("Sarvas field: the sensor lies at the centre of the sphere");
  const Vec3 a = r - r0;
  const double an = norm(a);
  const double ar = dot(a, r);
  const double F = an * (rn * an + rn * rn - dot(r0, r));
  if (!(F > 0))
    throw InputError("Sarvas field: the sensor lies on the dipole's ray within its radius (F = 0); sensors "
                     "must be outside the conductor");
  const Vec3 gradF = (an * an / rn + ar / an + 2 * an + 2 * rn) * r - (an + 2 * rn + ar / an) * r0;
  const Vec3 qr0 = cross(q, r0);
  return (kMegFemtoTesla / (F * F)) * (F * qr0 - dot(qr0, r) * gradF);
}

double triangleInverseDistanceIntegral(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& r) {
  const Vec3 p[3] = {a, b, c};
  const Vec3 n0 = cross(b - a, c - a);
  const double n0n = norm(n0);
  if (!(n0n > 0)) return 0.0; // degenerate triangle: zero area
  const Vec3 n = (1.0 / n0n) * n0;
  Vec3 d[3];
  double R[3];
  for (int i = 0; i < 3; ++i) d[i] = p[i] - r, R[i] = norm(d[i]);
  double sum = 0;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    const Vec3 e = p[j] - p[i];
    const double len = norm(e);
    const Vec3 l = (1.0 / len) * e;
    const Vec3 u = cross(l, n); // outward in the plane (counter-clockwise about n)
    const double t0 = dot(d[i], u);
    if (t0 == 0) continue;
    const double lp = dot(d[j], l), lm = dot(d[i], l);
    const Vec3 perp = cross(d[i], l);
    const double R0sq = dot(perp, perp);
    const double num = lp >= 0 ? R[j] + lp : R0sq / (R[j] - lp);
    const double den = lm >= 0 ? R[i] + lm : R0sq / (R[i] - lm);
    if (!(num > 0) || !(den > 0)) continue; // r on the edge's line: t0 = 0 in exact arithmetic
    sum += t0 * std::log(num / den);
  }
  const double h = std::abs(dot(d[0], n));
  const double trip = dot(d[0], cross(d[1], d[2]));
  const double den = R[0] * R[1] * R[2] + dot(d[0], d[1]) * R[2] + dot(d[0], d[2]) * R[1] + dot(d[1], d[2]) * R[0];
  const double omega = 2.0 * std::atan2(std::abs(trip), den);
  return sum - h * omega;
}

Vec3 tetBiotSavartKernel(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, const Vec3& r) {
  const Vec3 p[4] = {p0, p1, p2, p3};
  Vec3 d[4];
  double R[4];
  for (int i = 0; i < 4; ++i) d[i] = p[i] - r, R[i] = norm(d[i]);
  // Edge integrals L_e = int_e 1/|r - x| ds, shared by the two faces of the edge (they do not
  // depend on its direction), and the edges' unit vectors i -> j (i < j).
  static constexpr int E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  double L[6];
  Vec3 lhat[6];
  for (int e = 0; e < 6; ++e) {
    const int i = E[e][0], j = E[e][1];
    const Vec3 v = p[j] - p[i];
    lhat[e] = (1.0 / norm(v)) * v;
    const double lp = dot(d[j], lhat[e]), lm = dot(d[i], lhat[e]);
    const Vec3 perp = cross(d[i], lhat[e]);
    const double R0sq = dot(perp, perp);
    const double num = lp >= 0 ? R[j] + lp : R0sq / (R[j] - lp);
    const double den = lm >= 0 ? R[i] + lm : R0sq / (R[i] - lm);
    L[e] = (num > 0 && den > 0) ? std::log(num / den) : 0.0;
  }
  auto edgeIndex = [](int i, int j) {
    const int a = std::min(i, j), b = std::max(i, j);
    return a == 0 ? b - 1 : a == 1 ? b + 1 : 5; // (0,1)0 (0,2)1 (0,3)2 (1,2)3 (1,3)4 (2,3)5
  };
  Vec3 G{0, 0, 0};
  for (int k = 0; k < 4; ++k) { // face opposite vertex k
    int f[3], m = 0;
    for (int i = 0; i < 4; ++i)
      if (i != k) f[m++] = i;
    Vec3 nn = cross(p[f[1]] - p[f[0]], p[f[2]] - p[f[0]]);
    if (dot(nn, p[k] - p[f[0]]) > 0) std::swap(f[1], f[2]), nn = -1.0 * nn; // outward, counter-clockwise
    const double nl = norm(nn);
    if (!(nl > 0)) continue;
    const Vec3 n = (1.0 / nl) * nn;
    double sum = 0;
    for (int s = 0; s < 3; ++s) {
      const int i = f[s], j = f[(s + 1) % 3];
      const int e = edgeIndex(i, j);
      const Vec3 l = i < j ? lhat[e] : -1.0 * lhat[e];
      sum += dot(d[i], cross(l, n)) * L[e];
    }
    const double h = std::abs(dot(d[f[0]], n));
    const double trip = dot(d[f[0]], cross(d[f[1]], d[f[2]]));
    const double den = R[f[0]] * R[f[1]] * R[f[2]] + dot(d[f[0]], d[f[1]]) * R[f[2]] +
                       dot(d[f[0]], d[f[2]]) * R[f[1]] + dot(d[f[1]], d[f[2]]) * R[f[0]];
    const double I = sum - h * 2.0 * std::atan2(std::abs(trip), den);
    G = G + I * n;
  }
  return G;
}

std::vector<Vec3> megSensorKernels(const TetMesh& mesh, const MegSensor& sensor, Progress& progress) {
  const int64_t nt = int64_t(mesh.numTets());
  std::vector<Vec3> H(size_t(nt), Vec3{0, 0, 0});
  const int64_t chunk = 1 << 14;
  for (int64_t t0 = 0; t0 < nt; t0 += chunk) {
    progress.checkCancel();
    const int64_t t1 = std::min(nt, t0 + chunk);
#pragma omp parallel for schedule(static)
    for (int64_t t = t0; t < t1; ++t) {
      const auto& q = mesh.tets[size_t(t)];
      const Vec3 &a = mesh.points[size_t(q[0])], &b = mesh.points[size_t(q[1])], &c = mesh.points[size_t(q[2])],
                 &d = mesh.points[size_t(q[3])];
      Vec3 h{0, 0, 0};
      for (const MegCoil& coil : sensor.coils)
        h = h + coil.weight * cross(tetBiotSavartKernel(a, b, c, d, coil.position), coil.normal);
      H[size_t(t)] = h;
    }
  }
  return H;
}

// ---------------------------------------------------------------------------------------------
// MEG of one solution

MegResult computeMeg(const TetMesh& mesh, const std::vector<double>& potential, const MegParams& params,
                     Progress& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  mesh.validateStructure("mesh");
  if (mesh.numTets() == 0) throw InputError("mesh: no tets; the MEG needs the tetrahedral mesh of the FEM solve");
  if (potential.size() != mesh.numPoints())
    throw InputError("potential: " + std::to_string(potential.size()) + " values for " +
                     std::to_string(mesh.numPoints()) + " vertices");
  for (size_t i = 0; i < potential.size(); ++i)
    if (!std::isfinite(potential[i]))
      throw InputError("potential: vertex " + std::to_string(i) + " has a non-finite value");
  checkSensors(params.sensors);
  params.conductivities.validate();
  checkTetVolumes(mesh);
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(params.dipolePosition[size_t(k)]) || !std::isfinite(params.dipoleMoment[size_t(k)]))
      throw InputError("dipole: position and moment must be finite");

  MegResult res;
  const size_t nt = mesh.numTets(), ns = params.sensors.size();
  progress.beginStage("current density");
  const SigmaLookup sigma(mesh, params.conductivities);
  std::vector<Vec3> J(nt);
#pragma omp parallel for schedule(static)
  for (int64_t t = 0; t < int64_t(nt); ++t) {
    const TetGradients g = tetGradients(mesh, size_t(t));
    Vec3 grad{0, 0, 0};
    for (int a = 0; a < 4; ++a) grad = grad + potential[size_t(mesh.tets[size_t(t)][size_t(a)])] * g.grad[size_t(a)];
    J[size_t(t)] = mul(sigma(mesh.materials[size_t(t)]), grad);
  }
  progress.endStage();

  progress.beginStage("volume currents");
  std::vector<double> part(nt);
  for (size_t s = 0; s < ns; ++s) {
    progress.checkCancel();
    const MegSensor& sensor = params.sensors[s];
    // The kernels inline, so no per-tet array of H is held.
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < int64_t(nt); ++t) {
      const auto& q = mesh.tets[size_t(t)];
      double v = 0;
      for (const MegCoil& coil : sensor.coils) {
        const Vec3 G = tetBiotSavartKernel(mesh.points[size_t(q[0])], mesh.points[size_t(q[1])],
                                           mesh.points[size_t(q[2])], mesh.points[size_t(q[3])], coil.position);
        v += coil.weight * dot(J[size_t(t)], cross(G, coil.normal));
      }
      part[size_t(t)] = v;
    }
    double sum = 0;
    for (double v : part) sum += v; // tet order: independent of the thread count
    const double bv = -kMegFemtoTesla * sum;
    const double b0 = sensorSignal(sensor, [&](const Vec3& r) {
      return megPrimaryField(r, params.dipolePosition, params.dipoleMoment);
    });
    res.volume.push_back(bv);
    res.primary.push_back(b0);
    res.total.push_back(b0 + bv);
    progress.report(double(s + 1) / double(ns));
  }
  progress.endStage();
  res.coilsInsideMesh = coilsInside(mesh, params.sensors);
  if (res.coilsInsideMesh > 0)
    res.notes.push_back(std::to_string(res.coilsInsideMesh) + " coil(s) lie inside the mesh: MEG sensors belong "
                        "outside the head (the field there is still Biot-Savart's)");
  res.seconds = secondsSince(t0);
  return res;
}

// ---------------------------------------------------------------------------------------------
// Lead field

MegLeadFieldResult computeMegLeadField(const TetMesh& mesh, const MegLeadFieldParams& params, Progress& progress) {
  MegLeadFieldResult res;
  mesh.validateStructure("mesh");
  if (mesh.numTets() == 0) throw InputError("mesh: no tets; the MEG lead field needs a tetrahedral mesh");
  checkSensors(params.sensors);
  params.solver.validate();
  params.conductivities.validate();
  leadFieldSources(mesh, params.sourceLabels, params.sourcePoints, res.sources, res.sourceTets, progress);
  const size_t nc = params.sensors.size(), ns = res.sources.size(), np = mesh.numPoints(), nt = mesh.numTets();
  {
    const double bytes = 2 * 8.0 * double(nc) * 3.0 * double(ns) + 130.0 * double(nt);
    requireMemory(bytes, "the MEG lead field of " + std::to_string(nc) + " sensors x " + std::to_string(ns) + " sources",
                  [&](double avail) {
                    const double fits = std::floor(std::max(0.0, avail - 130.0 * double(nt)) / (48.0 * double(nc)));
                    std::ostringstream f;
                    f << "use at most " << fits << " sources (a source point list, or fewer source labels)";
                    return f.str();
                  });
  }
  for (const MegSensor& s : params.sensors) res.names.push_back(s.name);

  auto t0 = std::chrono::steady_clock::now();
  progress.beginStage("assemble");
  const SparseMatrix K = assembleStiffness(mesh, params.conductivities, progress);
  int32_t ncomp = 0;
  const std::vector<int32_t> comp = vertexComponents(mesh, ncomp);
  DirichletSet dir(np);
  {
    std::vector<uint8_t> anchored(size_t(std::max(ncomp, 0)), 0);
    for (size_t v = 0; v < np; ++v) {
      if (comp[v] < 0) {
        dir.set(v, 0.0);
      } else if (!anchored[size_t(comp[v])]) { // each piece: its lowest vertex at 0 V (the gauge)
        anchored[size_t(comp[v])] = 1;
        dir.set(v, 0.0);
      }
    }
  }
  ReducedSystem sys = eliminateDirichlet(K, Eigen::VectorXd::Zero(Eigen::Index(np)), dir);
  res.dofs = sys.K.rows();
  res.nnz = sys.K.nonZeros();
  progress.endStage();
  res.assembleSeconds = secondsSince(t0);

  res.matrix = Eigen::MatrixXd::Zero(Eigen::Index(nc), Eigen::Index(3 * ns));
  res.primary = Eigen::MatrixXd::Zero(Eigen::Index(nc), Eigen::Index(3 * ns));
  IterativeSolver solver(params.solver);
  solver.setOperator(sys.K);
  solver.setRightHandSides(int64_t(nc));
  solver.setProgress(&progress, false); // cancellable; the fraction is the sensors'
  res.setupSeconds = setUpTransferSolver(solver, progress, res.notes); // the factorisation once
  res.solverUsed = solverKindName(solver.params().kind);
  progress.beginStage("solve");
  const SigmaLookup sigma(mesh, params.conductivities);
  const auto& q = mesh.tets;
  const DipoleLoads loads = dipoleLoads(mesh, res.sources, res.sourceTets, params.sourceModel);
  double kSeconds = 0, mSeconds = 0, sSeconds = 0;
  // A direct solver takes blocks of sensors (transferBlockSize), the iterative ones one at a time.
  const size_t block = solver.direct() ? transferBlockSize(res.dofs) : 1;
  Eigen::MatrixXd B, X;
  Eigen::VectorXd x;
  for (size_t first = 0; first < nc; first += block) {
    progress.checkCancel();
    const size_t count = std::min(block, nc - first);
    // Adjoint load c_a = -k sum_T (sigma_T grad l_a) . H_T, scattered in tet order.
    auto tk = std::chrono::steady_clock::now();
    B = Eigen::MatrixXd::Zero(res.dofs, Eigen::Index(count));
    for (size_t j = 0; j < count; ++j) {
      // The kernels H_T (megSensorKernels, in parallel), then each tet's four contributions in
      // parallel, scattered in tet order by one thread: the same sums, in the same order, as a
      // serial pass.
      const std::vector<Vec3> H = megSensorKernels(mesh, params.sensors[first + j], progress);
      std::vector<std::array<double, 4>> w(nt);
#pragma omp parallel for schedule(static)
      for (int64_t t = 0; t < int64_t(nt); ++t) {
        const TetGradients g = tetGradients(mesh, size_t(t));
        const Vec3 sH = mul(sigma(mesh.materials[size_t(t)]), H[size_t(t)]); // sigma symmetric: (sigma g) . H = g . (sigma H)
        for (int k = 0; k < 4; ++k) w[size_t(t)][size_t(k)] = kMegFemtoTesla * dot(g.grad[size_t(k)], sH);
      }
      Eigen::VectorXd load = Eigen::VectorXd::Zero(Eigen::Index(np));
      for (size_t t = 0; t < nt; ++t)
        for (int a = 0; a < 4; ++a) load[q[t][size_t(a)]] -= w[t][size_t(a)];
      for (size_t v = 0; v < np; ++v)
        if (sys.reducedIndex[v] >= 0) B(sys.reducedIndex[v], Eigen::Index(j)) = load[Eigen::Index(v)];
    }
    kSeconds += secondsSince(tk);
    auto ts = std::chrono::steady_clock::now();
    if (solver.direct()) solver.solveBlock(B, X);
    sSeconds += secondsSince(ts);
    for (size_t j = 0; j < count; ++j) {
      const size_t c = first + j;
      const MegSensor& sensor = params.sensors[c];
      if (!solver.direct()) {
        ts = std::chrono::steady_clock::now();
        solver.solve(B.col(Eigen::Index(j)), x);
        sSeconds += secondsSince(ts);
      }
      countTransferSolve(res, solver, "sensor " + sensor.name);
      const auto tm = std::chrono::steady_clock::now();
      const Eigen::VectorXd u = solver.direct() ? sys.expand(X.col(Eigen::Index(j))) : sys.expand(x);
#pragma omp parallel for schedule(static)
      for (int64_t s = 0; s < int64_t(ns); ++s) {
        const Vec3& r0 = res.sources[size_t(s)];
        for (int k = 0; k < 3; ++k) {
          Vec3 e{0, 0, 0};
          e[size_t(k)] = 1.0;
          const double b0 = sensorSignal(sensor, [&](const Vec3& r) { return megPrimaryField(r, r0, e); });
          res.primary(Eigen::Index(c), Eigen::Index(3 * s + k)) = b0;
          res.matrix(Eigen::Index(c), Eigen::Index(3 * s + k)) = b0 + loads.apply(size_t(3 * s + k), u);
        }
      }
      mSeconds += secondsSince(tm);
      progress.report(double(c + 1) / double(nc));
    }
  }
  progress.endStage();
  res.kernelSeconds = kSeconds;
  res.solveSeconds = sSeconds;
  res.matrixSeconds = mSeconds;
  res.coilsInsideMesh = coilsInside(mesh, params.sensors);
  if (res.coilsInsideMesh > 0)
    res.notes.push_back(std::to_string(res.coilsInsideMesh) + " coil(s) lie inside the mesh: MEG sensors belong "
                        "outside the head");
  if (ncomp > 1)
    res.notes.push_back("the mesh has " + std::to_string(ncomp) + " separate pieces; each is solved with its own "
                        "zero-potential vertex");
  return res;
}

void writeMegLeadField(const MegLeadFieldResult& r, const std::vector<MegSensor>& sensors, const std::string& path) {
  writeLeadFieldMatrix(path, "MEG lead field", "sensor", r.names, r.matrix, r.sources, r.sourceTets);
  AtomicOutputFile out(path + ".sensors.csv", false);
  auto& s = out.stream();
  s << "name,coils,x,y,z,nx,ny,nz\n" << std::setprecision(10);
  for (const MegSensor& m : sensors) {
    const MegCoil& c = m.coils.front();
    s << m.name << ',' << m.coils.size() << ',' << c.position[0] << ',' << c.position[1] << ',' << c.position[2]
      << ',' << c.normal[0] << ',' << c.normal[1] << ',' << c.normal[2] << "\n";
  }
  out.commit();
}

MegErrors compareMeg(const std::vector<double>& u, const std::vector<double>& v) {
  if (u.empty() || u.size() != v.size())
    throw InputError("MEG comparison: " + std::to_string(u.size()) + " numerical and " + std::to_string(v.size()) +
                     " reference values; need the same non-zero count");
  double nu = 0, nv = 0;
  for (size_t i = 0; i < u.size(); ++i) {
    if (!std::isfinite(u[i]) || !std::isfinite(v[i])) throw InputError("MEG comparison: a non-finite value");
    nu += u[i] * u[i], nv += v[i] * v[i];
  }
  nu = std::sqrt(nu), nv = std::sqrt(nv);
  if (!(nu > 0) || !(nv > 0))
    throw InputError("MEG comparison: a field that is zero at every sensor (e.g. a radial dipole in a sphere) has "
                     "no RDM or MAG; use a tangential dipole");
  MegErrors e;
  double d = 0;
  for (size_t i = 0; i < u.size(); ++i) d += (u[i] / nu - v[i] / nv) * (u[i] / nu - v[i] / nv);
  e.rdm = std::sqrt(d);
  e.mag = nu / nv;
  e.lnMag = std::log(e.mag);
  return e;
}

} // namespace tetflow
