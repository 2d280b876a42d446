#pragma once
// The parts of a TetGen library call that every caller shares (TetgenDelaunay.cpp,
// SurfaceMeshing/TetgenSurface.cpp): the point list, and running tetrahedralize() with TetGen's
// `throw int` turned into a ProcessingError that names the reason. Include only from .cpp files
// that use TetGen (it includes tetgen.h).
#include <tetgen.h>

#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Geometry.h"

namespace tetflow::tetgencall {

inline void setPoints(tetgenio& in, const std::vector<Vec3>& points) {
  in.firstnumber = 0;
  in.numberofpoints = int(points.size());
  in.pointlist = new REAL[points.size() * 3];
  for (size_t i = 0; i < points.size(); ++i)
    for (int a = 0; a < 3; ++a) in.pointlist[3 * i + size_t(a)] = points[i][size_t(a)];
}

// Runs TetGen with `switches` (without '-'); `what` describes the input for the message
// ("1200 points", "a surface of 800 triangles").
inline void run(const std::string& switches, tetgenio& in, tetgenio& out, const std::string& what) {
  std::vector<char> buf(switches.begin(), switches.end());
  buf.push_back('\0');
  try {
    tetrahedralize(buf.data(), &in, &out);
  } catch (int code) {
    const char* why = code == 1   ? "out of memory"
                      : code == 2 ? "internal error"
                      : code == 3 ? "a self-intersection"
                      : code == 4 ? "a very small input feature size"
                      : code == 5 ? "two very close input facets"
                      : code == 10 ? "an input error"
                                  : "an unknown error";
    throw ProcessingError("TetGen failed (" + std::string(why) + ", code " + std::to_string(code) + ") on " + what +
                          " with switches -" + switches);
  }
  if (out.numberofcorners != 4) throw ProcessingError("TetGen returned elements that are not linear tets");
}

} // namespace tetflow::tetgencall
