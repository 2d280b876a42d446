// tetflow-volume: inspect, convert and generate label volumes from the command line.
//
//   tetflow-volume info FILE...                 dims, spacing, origin, axes, labels + voxel counts
//   tetflow-volume convert IN OUT               any supported format to any other (by extension)
//   tetflow-volume phantom KIND OUT [--voxel-size MM] [--radius MM]
//
// Exit status: 0 success, 1 bad input (message names the file/value), 2 bad arguments.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "Algorithms/Core/Errors.h"
#include "Algorithms/Core/Phantom.h"
#include "Algorithms/IO/VolumeIO.h"
#include "Interface/HugePages.h"

using namespace tetflow;

namespace {

int usage() {
  std::cerr << "usage:\n"
               "  tetflow-volume info FILE...\n"
               "  tetflow-volume convert IN OUT\n"
               "  tetflow-volume phantom head|sphere|two_spheres|shell|blob OUT"
               " [--voxel-size MM] [--radius MM]\n"
               "formats:";
  for (const auto& e : volumeExtensions()) std::cerr << ' ' << e;
  std::cerr << '\n';
  return 2;
}

void printInfo(const std::string& path) {
  const auto t0 = std::chrono::steady_clock::now();
  const RawVolume raw = readVolume(path);
  const LabelVolume v = toLabelVolume(raw, path);
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto& g = v.grid;
  std::printf("%s\n", path.c_str());
  std::printf("  read in      %.3f s (%s voxels)\n", secs, voxelTypeName(raw.type));
  std::printf("  dims         %lld x %lld x %lld (%lld voxels)\n", (long long)g.dims[0],
              (long long)g.dims[1], (long long)g.dims[2], (long long)g.voxelCount());
  std::printf("  spacing mm   %.6g %.6g %.6g\n", g.spacing[0], g.spacing[1], g.spacing[2]);
  std::printf("  origin mm    %.6g %.6g %.6g\n", g.origin[0], g.origin[1], g.origin[2]);
  if (!g.isAxisAligned())
    std::printf("  axes         i=(%.4g %.4g %.4g) j=(%.4g %.4g %.4g) k=(%.4g %.4g %.4g)\n",
                g.direction[0][0], g.direction[1][0], g.direction[2][0], g.direction[0][1],
                g.direction[1][1], g.direction[2][1], g.direction[0][2], g.direction[1][2],
                g.direction[2][2]);
  const auto counts = labelCounts(v);
  std::printf("  labels       %zu\n", counts.size());
  for (const auto& [label, n] : counts)
    std::printf("    %6d  %12lld voxels  %14.3f mm^3\n", label, (long long)n,
                double(n) * g.voxelVolume());
}

} // namespace

int main(int argc, char** argv) {
  tetflow::useTransparentHugePages(argv); // first: it may exec the program again
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) return usage();
  try {
    const std::string cmd = args[0];
    if (cmd == "info" && args.size() >= 2) {
      for (size_t i = 1; i < args.size(); ++i) printInfo(args[i]);
      return 0;
    }
    if (cmd == "convert" && args.size() == 3) {
      writeVolume(args[2], readVolume(args[1]));
      std::printf("wrote %s\n", args[2].c_str());
      return 0;
    }
    if (cmd == "phantom" && args.size() >= 3) {
      PhantomParams p;
      p.kind = phantomKindFromName(args[1]);
      for (size_t i = 3; i < args.size(); i += 2) {
        if (i + 1 >= args.size()) {
          std::cerr << "tetflow-volume: option " << args[i] << " needs a value\n";
          return 2;
        }
        double value = 0;
        try {
          size_t used = 0;
          value = std::stod(args[i + 1], &used);
          if (used != args[i + 1].size()) throw std::invalid_argument("");
        } catch (const std::exception&) {
          std::cerr << "tetflow-volume: " << args[i] << " '" << args[i + 1]
                    << "' is not a number\n";
          return 2;
        }
        if (args[i] == "--voxel-size") p.voxel_size = value;
        else if (args[i] == "--radius") {
          // Scale the head layers with the outer radius.
          const double s = value / p.radius;
          p.radius = value;
          p.skull_radius *= s;
          p.csf_radius *= s;
          p.brain_radius *= s;
        } else {
          std::cerr << "tetflow-volume: unknown option " << args[i] << '\n';
          return 2;
        }
      }
      const Phantom ph = makePhantom(p);
      writeVolume(args[2], fromLabelVolume(ph.volume));
      std::printf("wrote %s (%s phantom)\n", args[2].c_str(), phantomKindName(p.kind));
      return 0;
    }
    return usage();
  } catch (const Error& e) {
    std::cerr << "tetflow-volume: error: " << e.what() << '\n';
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "tetflow-volume: internal error: " << e.what() << '\n';
    return 1;
  }
}
