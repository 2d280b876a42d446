#pragma once
// Raw voxel bytes for the volume readers' tests (NRRD, INR): every voxel type, the bytes of values in
// either byte order, and a raw volume's values.
#include <algorithm>
#include <bit>
#include <cstring>
#include <string>
#include <vector>

#include "Algorithms/IO/RawVolume.h"

namespace tetflow::test {

inline constexpr VoxelType kAllTypes[] = {
    VoxelType::Int8,   VoxelType::UInt8, VoxelType::Int16,  VoxelType::UInt16,  VoxelType::Int32,
    VoxelType::UInt32, VoxelType::Int64, VoxelType::UInt64, VoxelType::Float32, VoxelType::Float64};

// Bytes of `values` in the requested byte order.
template <class T>
std::string bytesOf(const std::vector<T>& values, bool bigEndian) {
  std::string out(values.size() * sizeof(T), '\0');
  for (size_t i = 0; i < values.size(); ++i) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &values[i], sizeof(T));
    if (bigEndian == (std::endian::native == std::endian::little)) std::reverse(b, b + sizeof(T));
    std::memcpy(out.data() + i * sizeof(T), b, sizeof(T));
  }
  return out;
}

template <class T>
std::vector<T> valuesOf(const RawVolume& v) {
  std::vector<T> out(v.bytes.size() / sizeof(T));
  std::memcpy(out.data(), v.bytes.data(), out.size() * sizeof(T));
  return out;
}

} // namespace tetflow::test
