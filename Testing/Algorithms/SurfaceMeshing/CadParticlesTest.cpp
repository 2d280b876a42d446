// PSYS particles on the test models: every particle on its cell, the sizing field's three
// constraints (curvature, gap size, Lipschitz) met, hexagonal-like spacing, thread independence.
#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/SurfaceMeshing/CadParticles.h"
#include "Fixtures/CadModels.h"

using namespace tetflow;
using namespace tetflow::testing;

namespace {

PsysParams testParams(double maxSize) {
  PsysParams p;
  p.maxSize = maxSize;
  p.maxIterations = 150;
  return p;
}

// Nearest-neighbour distance / σ of each patch particle among the particles of its patch and
// its boundary (brute force).
std::vector<double> sampleSpacingRatios(const CadModel& m, const CadSample& s) {
  std::vector<double> out;
  for (size_t p = 0; p < s.onPatch.size(); ++p) {
    std::vector<int> pool(s.onPatch[p].begin(), s.onPatch[p].end());
    for (const auto& loop : m.patches()[p].loops)
      for (const auto& u : loop)
        if (u.curve >= 0) pool.insert(pool.end(), s.onCurve[u.curve].begin(), s.onCurve[u.curve].end());
    for (int i : s.onPatch[p]) {
      double best = INFINITY;
      for (int j : pool)
        if (j != i) best = std::min(best, norm(s.particles[i].x - s.particles[j].x));
      out.push_back(best / s.particles[i].sigma);
    }
  }
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

} // namespace

TEST(CadParticles, EnergyKernelIsTheModifiedCotangent) {
  EXPECT_EQ(psysEnergy(1.0, 1.0), 0.0);
  EXPECT_EQ(psysEnergy(2.0, 1.0), 0.0);
  EXPECT_NEAR(psysEnergy(0.5, 1.0), 1.0 / std::tan(M_PI / 4) + M_PI / 4 - M_PI / 2, 1e-15);
  EXPECT_NEAR(psysEnergy(1.0, 2.0), 2 * psysEnergy(0.5, 1.0), 1e-14); // scales with σ
  for (double r : {0.1, 0.3, 0.58, 0.9}) {
    const double h = 1e-6;
    EXPECT_NEAR(psysEnergyDerivative(r, 1.0), (psysEnergy(r + h, 1.0) - psysEnergy(r - h, 1.0)) / (2 * h), 1e-6);
    EXPECT_LT(psysEnergyDerivative(r, 1.0), 0.0); // repulsive
  }
}

TEST(CadParticles, ParticlesLieOnTheirCellsAndMeetTheSizingConstraints) {
  for (const auto& tm : testModels()) {
    SCOPED_TRACE(tm.name);
    auto m = modelOf(tm.make(), tm.name);
    PsysStats st;
    const PsysParams prm = testParams(3.0);
    CadSample s = sampleCadModel(*m, prm, &st);
    ASSERT_EQ(st.phases.size(), 3u);
    for (const auto& ph : st.phases) EXPECT_GT(ph.iterations, 0) << ph.name;
    ASSERT_GE(s.particles.size(), m->corners().size());
    for (size_t c = 0; c < m->corners().size(); ++c) {
      EXPECT_EQ(s.particles[c].dim, 0);
      EXPECT_LT(norm(s.particles[c].x - m->corners()[c]), 1e-12);
    }
    for (size_t c = 0; c < s.onCurve.size(); ++c) {
      const CadCurve& cv = m->curves()[c];
      EXPECT_GE(s.onCurve[c].size(), cv.corner0 == cv.corner1 ? 2u : 1u);
      double prev = cv.t0;
      for (int i : s.onCurve[c]) {
        const CadParticle& q = s.particles[i];
        EXPECT_GT(q.t, prev);
        EXPECT_LT(q.t, cv.t1);
        prev = q.t;
        EXPECT_LT(norm(q.x - m->curvePoint(int(c), q.t)), 1e-9);
      }
    }
    for (size_t p = 0; p < s.onPatch.size(); ++p)
      for (int i : s.onPatch[p]) {
        const CadParticle& q = s.particles[i];
        EXPECT_LT(norm(q.x - m->patchPoint(int(p), q.uv.x, q.uv.y).p), 1e-9);
        // Curvature bound: σ ≤ 1/(s_κ κ) (up to σ_min).
        const double k = m->patchMaxCurvature(int(p), q.uv.x, q.uv.y);
        if (k > 0) {
          EXPECT_LE(q.sigma, std::max(st.minSize, 1.0 / (prm.sKappa * k)) * (1 + 1e-3)); // κ of the last move
        }
        EXPECT_LE(q.sigma, st.maxSize * (1 + 1e-12));
        EXPECT_GE(q.sigma, st.minSize * (1 - 1e-12));
      }
    // Spacing close to the hexagonal packing's 0.577 σ.
    const double med = median(sampleSpacingRatios(*m, s));
    EXPECT_GT(med, 0.40);
    EXPECT_LT(med, 0.80);
    // Lipschitz: |σ_i − σ_j| ≤ L r (+10 % for the iteration's lag) for 95 % of the neighbours.
    int violations = 0, pairs = 0;
    for (size_t i = 0; i < s.particles.size(); ++i)
      for (size_t j = i + 1; j < s.particles.size(); ++j) {
        const double r = norm(s.particles[i].x - s.particles[j].x);
        if (r > std::max(s.particles[i].sigma, s.particles[j].sigma)) continue;
        ++pairs;
        if (std::abs(s.particles[i].sigma - s.particles[j].sigma) > 1.1 * prm.lipschitz * r + 1e-9) ++violations;
      }
    EXPECT_LE(violations, pairs / 20) << violations << " of " << pairs;
  }
}

TEST(CadParticles, GapSizeRefinesAThinPlate) {
  // The plate is 1.5 mm thick: its top and bottom faces are not adjacent, so σ ≤ s_τ · 1.5 on
  // them (the side faces and the holes are adjacent to both).
  auto m = modelOf(thinPlateWithHoles(), "plate");
  PsysParams prm = testParams(6.0);
  PsysStats st;
  CadSample s = sampleCadModel(*m, prm, &st);
  int onFaces = 0;
  for (size_t p = 0; p < s.onPatch.size(); ++p)
    for (int i : s.onPatch[p]) {
      const CadParticle& q = s.particles[i];
      if (std::abs(m->patchNormal(int(p), q.uv.x, q.uv.y)[2]) < 0.99) continue;
      ++onFaces;
      EXPECT_LE(s.particles[i].sigma, prm.sTau * 1.5 * 1.05) << "patch " << p;
    }
  EXPECT_GT(onFaces, 100);
}

TEST(CadParticles, SameSampleOnOneAndTwoThreads) {
  auto m = modelOf(cylinderWithCap(), "cap");
  const PsysParams prm = testParams(2.5);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  CadSample a = sampleCadModel(*m, prm);
  omp_set_num_threads(2);
  CadSample b = sampleCadModel(*m, prm);
  omp_set_num_threads(threads);
  ASSERT_EQ(a.particles.size(), b.particles.size());
  for (size_t i = 0; i < a.particles.size(); ++i) EXPECT_EQ(a.particles[i].x, b.particles[i].x);
}

TEST(CadParticles, BadParametersAreNamed) {
  auto m = modelOf(torus(), "torus");
  auto msg = [&](PsysParams p) {
    try {
      sampleCadModel(*m, p);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  PsysParams p;
  p.sKappa = 0;
  EXPECT_NE(msg(p).find("s_kappa"), std::string::npos);
  p = {};
  p.sTau = 2;
  EXPECT_NE(msg(p).find("s_tau"), std::string::npos);
  p = {};
  p.lipschitz = 1;
  EXPECT_NE(msg(p).find("lipschitz"), std::string::npos);
  p = {};
  p.minSize = 5;
  p.maxSize = 1;
  EXPECT_NE(msg(p).find("min_size"), std::string::npos);
}
