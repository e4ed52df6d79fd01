// Helpers for the grade tests: seeded random tables and colours, and OpenColorIO's own
// FileTransform as the independent reference.
#pragma once

#include <filesystem>
#include <random>
#include <vector>

#include "encode/grade/lut.hpp"

namespace hdrd::grade_testing {

// A 3D table with smooth structure plus noise, values roughly in [-0.1, 1.2].
lut::Lut3D random_lut3d(int size, std::mt19937& rng);
lut::Lut1D random_lut1d(int size, std::mt19937& rng);
// Colours in [lo, hi]^3.
std::vector<lut::Rgb> random_colours(int count, float lo, float hi, std::mt19937& rng);

// OpenColorIO FileTransform + default CPU processor, applied to one colour at a time.
class OcioFile {
 public:
  OcioFile(const std::filesystem::path& path, bool tetrahedral);
  ~OcioFile();
  lut::Rgb apply(lut::Rgb in) const;

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace hdrd::grade_testing
