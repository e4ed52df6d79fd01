// The GPU encode pass: the program encode/kernel/gpu_program.hpp generates from the CPU
// pipeline (the single source of truth for constants, curves and tables), run over the
// rendered frame by a GpuPass. The CPU encoder (encode_frame) is the oracle: the codes
// agree within 1 (tests/shading/gpu_encode_test.cpp).
#pragma once

#include <memory>

#include "encode/kernel/gpu_program.hpp"
#include "encode/pipeline.hpp"
#include "shading/gpu_pass.hpp"
#include "shading/renderer.hpp"

namespace hdrd::shading {

struct GpuEncodeResult {
  EncodedFrame frame;
  double gpu_ms = 0;       // the pass, glFinish-bounded
  double readback_ms = 0;  // at the output format (packed words)
};

class GpuEncoder {
 public:
  // Fails with "gpu.unsupported" when the pipeline needs the CPU (RGB-operator curves,
  // grading LUTs, dither, sRGB-space UI blending): encode on the CPU then.
  static Result<std::unique_ptr<GpuEncoder>> create(Renderer& renderer, const PreparedPipeline& prepared);

  // Encodes the renderer's last frame (absolute cd/m2, linear Rec.709).
  Result<GpuEncodeResult> encode();
  // Encodes an image as the pipeline's input (tests).
  Result<GpuEncodeResult> encode_image(const Image& image);

 private:
  GpuEncoder(PreparedPipeline p, gpu::EncodeProgram prog, std::unique_ptr<GpuPass> pass)
      : prepared_(std::move(p)), program_(std::move(prog)), pass_(std::move(pass)) {}
  Result<GpuEncodeResult> finish(Result<PassResult> r);
  PreparedPipeline prepared_;
  gpu::EncodeProgram program_;
  std::unique_ptr<GpuPass> pass_;
};

}  // namespace hdrd::shading
