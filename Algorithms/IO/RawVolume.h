#pragma once
// A volume as stored in a file: grid geometry plus voxel values in their native type, already in
// the host's byte order. Every format reader produces one; toLabelVolume / toScalarVolume turn it
// into what the algorithms use, with the checks that belong there (labels must be integers in
// int32 range; scalars must be finite).
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "../Core/Volume.h"

namespace tetflow {

// Values are explicit and stable (saved choices, DESIGN §7).
enum class VoxelType : int {
  Int8 = 0, UInt8 = 1, Int16 = 2, UInt16 = 3, Int32 = 4, UInt32 = 5, Int64 = 6, UInt64 = 7,
  Float32 = 8, Float64 = 9
};
size_t voxelTypeSize(VoxelType t);
const char* voxelTypeName(VoxelType t); // "uint8", "float32", ...
bool voxelTypeIsInteger(VoxelType t);
bool voxelTypeIsSigned(VoxelType t);

struct RawVolume {
  GridGeometry grid;
  VoxelType type = VoxelType::UInt8;
  std::vector<unsigned char> bytes; // voxelCount * voxelTypeSize(type), host byte order
  std::map<int32_t, std::string> labelNames; // names the file itself gives its labels (3D Slicer's .seg.nrrd)

  double valueAsDouble(int64_t index) const;
};

// Reverse the byte order of `count` values of `size` bytes each, in place.
void byteSwapInPlace(unsigned char* data, size_t count, size_t size);
bool hostIsLittleEndian();

// Checked conversions; `what` (usually the file name) prefixes every message.
LabelVolume toLabelVolume(const RawVolume& raw, const std::string& what);
ScalarVolume toScalarVolume(const RawVolume& raw, const std::string& what);

// Wrap a label / scalar volume for writing. Labels are stored in the smallest integer type that
// holds all their values (uint8 for 0..255, int16, ...), unless `type` is given.
RawVolume fromLabelVolume(const LabelVolume& v);
RawVolume fromLabelVolume(const LabelVolume& v, VoxelType type);
RawVolume fromScalarVolume(const ScalarVolume& v);

} // namespace tetflow
