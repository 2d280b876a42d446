#pragma once
// Compass (pattern) search for one vertex position, shared by the cleaver's angle optimisation
// and the mesh improvement: from `start`, try steps along 14 directions (the axes and the cube
// diagonals), restricted to the vertex's freedom (free, in the plane with normal `dir`, or along
// `dir`), keep any trial that raises the objective by more than minGain, repeat up to 4 rounds
// per step length, then halve the step, from initialStep down to finalStep. Trials farther than
// maxMove from `start` are skipped. Deterministic; no allocation.
#include <cmath>

#include "Geometry.h"

namespace tetflow {

struct PatternSearch {
  int dof = 3;             // 3 free, 2 in the plane with normal dir, 1 along dir, 0 fixed
  Vec3 dir{0, 0, 0};       // unit
  double initialStep = 0;  // mm
  double finalStep = 0;    // mm: stop once the step is no longer above this
  double maxMove = 0;      // mm from start
  double minGain = 1e-9;   // an improvement must exceed this

  // objective(trial, floor) gives the value at `trial`, or anything <= floor once it knows the
  // trial will not beat floor (for early exits). adjust(trial) may correct a trial before it is
  // scored (e.g. restore coordinates that must not change). accepted() is called after each
  // improvement, with the objective's last evaluation still current. Returns the best position;
  // *best holds its value (pass the value at start).
  template <class Objective, class Adjust, class Accepted>
  Vec3 run(const Vec3& start, double& best, Objective&& objective, Adjust&& adjust, Accepted&& accepted) const {
    static const Vec3 dirs[] = {{1, 0, 0},   {-1, 0, 0}, {0, 1, 0},   {0, -1, 0}, {0, 0, 1},   {0, 0, -1}, {1, 1, 1},
                                {-1, -1, -1}, {1, -1, 1}, {-1, 1, -1}, {1, 1, -1}, {-1, -1, 1}, {-1, 1, 1}, {1, -1, -1}};
    Vec3 bestPos = start;
    if (dof == 0) return bestPos;
    for (double step = initialStep; step > finalStep; step *= 0.5) {
      bool improved = true;
      for (int rounds = 0; improved && rounds < 4; ++rounds) {
        improved = false;
        const Vec3 base = bestPos;
        for (const Vec3& d0 : dirs) {
          Vec3 d = d0;
          if (dof == 2) d = d - dot(d, dir) * dir;
          if (dof == 1) d = dot(d, dir) * dir;
          const double nd = norm(d);
          if (!(nd > 1e-6)) continue;
          Vec3 trial = base + (step / nd) * d;
          adjust(trial);
          if (norm(trial - start) > maxMove) continue;
          const double w = objective(trial, best + minGain);
          if (w > best + minGain) {
            best = w;
            bestPos = trial;
            improved = true;
            accepted();
          }
        }
      }
    }
    return bestPos;
  }
};

} // namespace tetflow
