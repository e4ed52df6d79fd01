#include "tests/encode/grade/grade_testing.hpp"

#include <OpenColorIO/OpenColorIO.h>

#include <cmath>

namespace OCIO = OCIO_NAMESPACE;

namespace hdrd::grade_testing {

lut::Lut3D random_lut3d(int size, std::mt19937& rng) {
  std::uniform_real_distribution<float> noise(-0.1f, 0.1f);
  lut::Lut3D l = lut::Lut3D::identity(size);
  for (std::size_t i = 0; i < l.rgb.size(); i += 3) {
    const float r = l.rgb[i], g = l.rgb[i + 1], b = l.rgb[i + 2];
    l.rgb[i] = 0.8f * r + 0.2f * g * g + noise(rng);
    l.rgb[i + 1] = std::sqrt(g) * 0.9f + 0.1f * b + noise(rng);
    l.rgb[i + 2] = b * b + 0.2f * r + noise(rng);
  }
  return l;
}

lut::Lut1D random_lut1d(int size, std::mt19937& rng) {
  std::uniform_real_distribution<float> noise(-0.02f, 0.02f);
  lut::Lut1D l = lut::Lut1D::identity(size);
  for (std::size_t i = 0; i < l.rgb.size(); ++i) l.rgb[i] = std::pow(l.rgb[i], 0.8f + 0.1f * float(i % 3)) + noise(rng);
  return l;
}

std::vector<lut::Rgb> random_colours(int count, float lo, float hi, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<lut::Rgb> out(count);
  for (auto& c : out) c = {u(rng), u(rng), u(rng)};
  return out;
}

struct OcioFile::Impl {
  OCIO::ConstCPUProcessorRcPtr cpu;
};

OcioFile::OcioFile(const std::filesystem::path& path, bool tetrahedral) : impl_(new Impl) {
  OCIO::ClearAllCaches();
  auto cfg = OCIO::Config::CreateRaw();
  auto ft = OCIO::FileTransform::Create();
  ft->setSrc(path.c_str());
  ft->setInterpolation(tetrahedral ? OCIO::INTERP_TETRAHEDRAL : OCIO::INTERP_LINEAR);
  impl_->cpu = cfg->getProcessor(ft)->getDefaultCPUProcessor();
}

OcioFile::~OcioFile() { delete impl_; }

lut::Rgb OcioFile::apply(lut::Rgb in) const {
  impl_->cpu->applyRGB(in.data());
  return in;
}

}  // namespace hdrd::grade_testing
