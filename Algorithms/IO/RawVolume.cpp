#include "RawVolume.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <sstream>

#include "../Core/Errors.h"

namespace tetflow {

size_t voxelTypeSize(VoxelType t) {
  switch (t) {
    case VoxelType::Int8: case VoxelType::UInt8: return 1;
    case VoxelType::Int16: case VoxelType::UInt16: return 2;
    case VoxelType::Int32: case VoxelType::UInt32: case VoxelType::Float32: return 4;
    case VoxelType::Int64: case VoxelType::UInt64: case VoxelType::Float64: return 8;
  }
  return 0;
}

const char* voxelTypeName(VoxelType t) {
  switch (t) {
    case VoxelType::Int8: return "int8";
    case VoxelType::UInt8: return "uint8";
    case VoxelType::Int16: return "int16";
    case VoxelType::UInt16: return "uint16";
    case VoxelType::Int32: return "int32";
    case VoxelType::UInt32: return "uint32";
    case VoxelType::Int64: return "int64";
    case VoxelType::UInt64: return "uint64";
    case VoxelType::Float32: return "float32";
    case VoxelType::Float64: return "float64";
  }
  return "?";
}

bool voxelTypeIsInteger(VoxelType t) { return t != VoxelType::Float32 && t != VoxelType::Float64; }
bool voxelTypeIsSigned(VoxelType t) {
  return t == VoxelType::Int8 || t == VoxelType::Int16 || t == VoxelType::Int32 ||
         t == VoxelType::Int64 || !voxelTypeIsInteger(t);
}

bool hostIsLittleEndian() { return std::endian::native == std::endian::little; }

void byteSwapInPlace(unsigned char* data, size_t count, size_t size) {
  if (size <= 1) return;
  for (size_t i = 0; i < count; ++i) std::reverse(data + i * size, data + (i + 1) * size);
}

namespace {

template <class T>
T load(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

// Calls f(index, value) for every voxel with its native type; parallel.
template <class F>
void forEachValue(const RawVolume& raw, F&& f) {
  const int64_t n = raw.grid.voxelCount();
  const unsigned char* b = raw.bytes.data();
  auto run = [&](auto tag) {
    using T = decltype(tag);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) f(i, load<T>(b + i * sizeof(T)));
  };
  switch (raw.type) {
    case VoxelType::Int8: run(int8_t{}); break;
    case VoxelType::UInt8: run(uint8_t{}); break;
    case VoxelType::Int16: run(int16_t{}); break;
    case VoxelType::UInt16: run(uint16_t{}); break;
    case VoxelType::Int32: run(int32_t{}); break;
    case VoxelType::UInt32: run(uint32_t{}); break;
    case VoxelType::Int64: run(int64_t{}); break;
    case VoxelType::UInt64: run(uint64_t{}); break;
    case VoxelType::Float32: run(float{}); break;
    case VoxelType::Float64: run(double{}); break;
  }
}

void checkSize(const RawVolume& raw, const std::string& what) {
  raw.grid.validate(what);
  const size_t want = static_cast<size_t>(raw.grid.voxelCount()) * voxelTypeSize(raw.type);
  if (raw.bytes.size() != want) {
    std::ostringstream m;
    m << what << ": holds " << raw.bytes.size() << " bytes of voxel data, expected " << want;
    throw InputError(m.str());
  }
}

std::string voxelName(const GridGeometry& g, int64_t i) {
  std::ostringstream m;
  m << "(" << i % g.dims[0] << ", " << (i / g.dims[0]) % g.dims[1] << ", "
    << i / (g.dims[0] * g.dims[1]) << ")";
  return m.str();
}

} // namespace

double RawVolume::valueAsDouble(int64_t i) const {
  const unsigned char* p = bytes.data() + static_cast<size_t>(i) * voxelTypeSize(type);
  switch (type) {
    case VoxelType::Int8: return load<int8_t>(p);
    case VoxelType::UInt8: return load<uint8_t>(p);
    case VoxelType::Int16: return load<int16_t>(p);
    case VoxelType::UInt16: return load<uint16_t>(p);
    case VoxelType::Int32: return load<int32_t>(p);
    case VoxelType::UInt32: return load<uint32_t>(p);
    case VoxelType::Int64: return static_cast<double>(load<int64_t>(p));
    case VoxelType::UInt64: return static_cast<double>(load<uint64_t>(p));
    case VoxelType::Float32: return load<float>(p);
    case VoxelType::Float64: return load<double>(p);
  }
  return 0.0;
}

LabelVolume toLabelVolume(const RawVolume& raw, const std::string& what) {
  checkSize(raw, what);
  LabelVolume out;
  out.grid = raw.grid;
  out.data.resize(static_cast<size_t>(raw.grid.voxelCount()));
  const int64_t n = raw.grid.voxelCount();
  int64_t bad = n; // first voxel whose value is not an int32 label
#pragma omp parallel
  {
    int64_t localBad = n;
    forEachValue(raw, [&](int64_t i, auto v) {
      using T = decltype(v);
      bool ok;
      if constexpr (std::is_floating_point_v<T>) {
        ok = std::isfinite(v) && v == std::floor(v) &&
             v >= static_cast<T>(std::numeric_limits<int32_t>::min()) &&
             v <= static_cast<T>(std::numeric_limits<int32_t>::max());
      } else if constexpr (std::is_signed_v<T>) {
        ok = static_cast<int64_t>(v) >= std::numeric_limits<int32_t>::min() &&
             static_cast<int64_t>(v) <= std::numeric_limits<int32_t>::max();
      } else {
        ok = static_cast<uint64_t>(v) <= static_cast<uint64_t>(std::numeric_limits<int32_t>::max());
      }
      if (ok) out.data[static_cast<size_t>(i)] = static_cast<int32_t>(v);
      else if (i < localBad) localBad = i;
    });
#pragma omp critical
    bad = std::min(bad, localBad);
  }
  if (bad < n) {
    std::ostringstream m;
    m << what << ": voxel " << voxelName(raw.grid, bad) << " holds " << raw.valueAsDouble(bad)
      << ", which is not a label (labels are whole numbers in the int32 range); "
         "read scalar data such as indicator functions with ReadIndicatorFunctions instead";
    throw InputError(m.str());
  }
  return out;
}

ScalarVolume toScalarVolume(const RawVolume& raw, const std::string& what) {
  checkSize(raw, what);
  ScalarVolume out;
  out.grid = raw.grid;
  out.data.resize(static_cast<size_t>(raw.grid.voxelCount()));
  forEachValue(raw, [&](int64_t i, auto v) {
    out.data[static_cast<size_t>(i)] = static_cast<float>(v);
  });
  requireFinite(out, what);
  return out;
}

RawVolume fromLabelVolume(const LabelVolume& v, VoxelType type) {
  if (!voxelTypeIsInteger(type) && type != VoxelType::Float32 && type != VoxelType::Float64)
    throw InputError("unsupported label type");
  RawVolume raw;
  raw.grid = v.grid;
  raw.type = type;
  const size_t sz = voxelTypeSize(type);
  raw.bytes.resize(v.data.size() * sz);
  const int64_t n = static_cast<int64_t>(v.data.size());
  auto run = [&](auto tag) {
    using T = decltype(tag);
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
      const T x = static_cast<T>(v.data[static_cast<size_t>(i)]);
      std::memcpy(raw.bytes.data() + i * sizeof(T), &x, sizeof(T));
    }
  };
  switch (type) {
    case VoxelType::Int8: run(int8_t{}); break;
    case VoxelType::UInt8: run(uint8_t{}); break;
    case VoxelType::Int16: run(int16_t{}); break;
    case VoxelType::UInt16: run(uint16_t{}); break;
    case VoxelType::Int32: run(int32_t{}); break;
    case VoxelType::UInt32: run(uint32_t{}); break;
    case VoxelType::Int64: run(int64_t{}); break;
    case VoxelType::UInt64: run(uint64_t{}); break;
    case VoxelType::Float32: run(float{}); break;
    case VoxelType::Float64: run(double{}); break;
  }
  return raw;
}

RawVolume fromLabelVolume(const LabelVolume& v) {
  int32_t lo = 0, hi = 0;
  if (!v.data.empty()) {
    auto [mn, mx] = std::minmax_element(v.data.begin(), v.data.end());
    lo = *mn;
    hi = *mx;
  }
  VoxelType t = VoxelType::Int32;
  if (lo >= 0 && hi <= 255) t = VoxelType::UInt8;
  else if (lo >= -128 && hi <= 127) t = VoxelType::Int8;
  else if (lo >= 0 && hi <= 65535) t = VoxelType::UInt16;
  else if (lo >= -32768 && hi <= 32767) t = VoxelType::Int16;
  return fromLabelVolume(v, t);
}

RawVolume fromScalarVolume(const ScalarVolume& v) {
  RawVolume raw;
  raw.grid = v.grid;
  raw.type = VoxelType::Float32;
  raw.bytes.resize(v.data.size() * sizeof(float));
  if (!v.data.empty()) std::memcpy(raw.bytes.data(), v.data.data(), raw.bytes.size());
  return raw;
}

} // namespace tetflow
