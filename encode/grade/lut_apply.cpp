// The CPU fast path for 3D LUTs: Highway SIMD with dynamic dispatch (the build needs no
// AVX2; SSE4/AVX2/AVX-512 kernels are compiled and the best one the CPU has is chosen at
// run time), interleaved RGBA float or half in, lattice lookups by gather, and the same
// tetrahedral / trilinear formulas as lut::eval (OCIO Lut3DOpCPU) so results agree to
// float rounding.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "encode/grade/lut_apply.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/highway.h>

#include <algorithm>
#include <cstring>

#include "encode/grade/lut.hpp"
#include "encode/parallel.hpp"

#ifndef HDRD_LUT_APPLY_ARGS
#define HDRD_LUT_APPLY_ARGS
namespace hdrd::lut::detail {
// What the kernel needs; the table is RGBX (4 floats per lattice entry) so one index
// shift reaches all three channels of an entry in the same cache line.
struct KernelArgs {
  const float* table;
  int size;
  bool tetrahedral;
  float min[3];
  float scale[3];  // (size - 1) / (max - min)
};
}  // namespace hdrd::lut::detail
#endif

HWY_BEFORE_NAMESPACE();
namespace hdrd::lut::HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;
using detail::KernelArgs;

// Lattice cell index (in RGBX entries) and fractions of one channel, clamped to the
// table (a NaN input lands on 0, as in lut::eval).
template <class D, class DI>
HWY_INLINE void Cell(D d, DI di, const KernelArgs& k, int c, hn::Vec<D> x, hn::Vec<DI>& i, hn::Vec<D>& f) {
  const auto top = hn::Set(d, float(k.size - 1));
  auto t = hn::Mul(hn::Sub(x, hn::Set(d, k.min[c])), hn::Set(d, k.scale[c]));
  t = hn::Min(hn::Max(t, hn::Zero(d)), top);
  i = hn::Min(hn::ConvertTo(di, t), hn::Set(di, k.size - 2));
  f = hn::Sub(t, hn::ConvertTo(d, i));
}

template <class D, class VI>
HWY_INLINE hn::Vec<D> Fetch(D d, const float* table, int channel, VI entry) {
  return hn::GatherIndex(d, table + channel, hn::ShiftLeft<2>(entry));
}

template <class D>
HWY_INLINE void Lookup(D d, const KernelArgs& k, hn::Vec<D>& r, hn::Vec<D>& g, hn::Vec<D>& b) {
  const hn::RebindToSigned<D> di;
  using VI = hn::Vec<decltype(di)>;
  using V = hn::Vec<D>;
  VI ir, ig, ib;
  V fr, fg, fb;
  Cell(d, di, k, 0, r, ir, fr);
  Cell(d, di, k, 1, g, ig, fg);
  Cell(d, di, k, 2, b, ib, fb);
  const int n = k.size;
  const VI dr = hn::Set(di, 1), dg = hn::Set(di, n), db = hn::Set(di, n * n), dall = hn::Set(di, 1 + n + n * n);
  const VI base = hn::Add(ir, hn::Add(hn::Mul(ig, dg), hn::Mul(ib, db)));
  V out[3];
  if (k.tetrahedral) {
    // Sorted fractions f1 >= f2 >= f3 and the corners n000, the max axis, the two
    // largest axes, n111: out = (1-f1) n000 + (f1-f2) nA + (f2-f3) nAB + f3 n111.
    const auto m_rg = hn::Ge(fr, fg), m_gb = hn::Ge(fg, fb), m_rb = hn::Ge(fr, fb);
    const V f1 = hn::Max(hn::Max(fr, fg), fb);
    const V f3 = hn::Min(hn::Min(fr, fg), fb);
    const V f2 = hn::Max(hn::Min(fr, fg), hn::Min(hn::Max(fr, fg), fb));
    const auto r_max = hn::RebindMask(di, hn::And(m_rg, m_rb));
    const auto g_max = hn::RebindMask(di, hn::AndNot(m_rg, m_gb));
    const auto b_min = hn::RebindMask(di, hn::And(m_gb, m_rb));
    const auto g_min = hn::RebindMask(di, m_rg);
    const VI off_a = hn::IfThenElse(r_max, dr, hn::IfThenElse(g_max, dg, db));
    const VI off_ab = hn::Sub(dall, hn::IfThenElse(b_min, db, hn::IfThenElse(g_min, dg, dr)));
    const VI e0 = base, ea = hn::Add(base, off_a), eab = hn::Add(base, off_ab), e1 = hn::Add(base, dall);
    const V one = hn::Set(d, 1.0f);
    const V w0 = hn::Sub(one, f1), wa = hn::Sub(f1, f2), wab = hn::Sub(f2, f3);
    for (int c = 0; c < 3; ++c) {
      V v = hn::Mul(w0, Fetch(d, k.table, c, e0));
      v = hn::MulAdd(wa, Fetch(d, k.table, c, ea), v);
      v = hn::MulAdd(wab, Fetch(d, k.table, c, eab), v);
      out[c] = hn::MulAdd(f3, Fetch(d, k.table, c, e1), v);
    }
  } else {
    const VI e000 = base, e100 = hn::Add(base, dr), e010 = hn::Add(base, dg), e110 = hn::Add(e010, dr);
    const VI e001 = hn::Add(base, db), e101 = hn::Add(e001, dr), e011 = hn::Add(e001, dg), e111 = hn::Add(base, dall);
    const auto lerp = [](V a, V b, V t) { return hn::MulAdd(hn::Sub(b, a), t, a); };
    for (int c = 0; c < 3; ++c) {
      const float* t = k.table;
      const V c00 = lerp(Fetch(d, t, c, e000), Fetch(d, t, c, e100), fr);
      const V c10 = lerp(Fetch(d, t, c, e010), Fetch(d, t, c, e110), fr);
      const V c01 = lerp(Fetch(d, t, c, e001), Fetch(d, t, c, e101), fr);
      const V c11 = lerp(Fetch(d, t, c, e011), Fetch(d, t, c, e111), fr);
      out[c] = lerp(lerp(c00, c10, fg), lerp(c01, c11, fg), fb);
    }
  }
  r = out[0];
  g = out[1];
  b = out[2];
}

void ApplyFloat(const KernelArgs& k, float* HWY_RESTRICT rgba, std::size_t pixels) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  hn::Vec<decltype(d)> r, g, b, a;
  std::size_t i = 0;
  for (; i + lanes <= pixels; i += lanes) {
    hn::LoadInterleaved4(d, rgba + 4 * i, r, g, b, a);
    Lookup(d, k, r, g, b);
    hn::StoreInterleaved4(r, g, b, a, d, rgba + 4 * i);
  }
  if (i == pixels) return;
  HWY_ALIGN float tail[4 * (HWY_MAX_BYTES / sizeof(float))] = {};
  const std::size_t rest = pixels - i;
  std::memcpy(tail, rgba + 4 * i, rest * 4 * sizeof(float));
  hn::LoadInterleaved4(d, tail, r, g, b, a);
  Lookup(d, k, r, g, b);
  hn::StoreInterleaved4(r, g, b, a, d, tail);
  std::memcpy(rgba + 4 * i, tail, rest * 4 * sizeof(float));
}

void ApplyHalf(const KernelArgs& k, const std::uint16_t* in, std::uint16_t* out, std::size_t pixels) {
  const hn::ScalableTag<float> d;
  const hn::Rebind<std::uint16_t, decltype(d)> du;
  const hn::Rebind<hwy::float16_t, decltype(d)> dh;
  const std::size_t lanes = hn::Lanes(d);
  const auto run = [&](const std::uint16_t* src, std::uint16_t* dst) {
    hn::Vec<decltype(du)> r16, g16, b16, a16;
    hn::LoadInterleaved4(du, src, r16, g16, b16, a16);
    auto r = hn::PromoteTo(d, hn::BitCast(dh, r16));
    auto g = hn::PromoteTo(d, hn::BitCast(dh, g16));
    auto b = hn::PromoteTo(d, hn::BitCast(dh, b16));
    Lookup(d, k, r, g, b);
    hn::StoreInterleaved4(hn::BitCast(du, hn::DemoteTo(dh, r)), hn::BitCast(du, hn::DemoteTo(dh, g)),
                          hn::BitCast(du, hn::DemoteTo(dh, b)), a16, du, dst);
  };
  std::size_t i = 0;
  for (; i + lanes <= pixels; i += lanes) run(in + 4 * i, out + 4 * i);
  if (i == pixels) return;
  HWY_ALIGN std::uint16_t tail[4 * (HWY_MAX_BYTES / sizeof(float))] = {};
  const std::size_t rest = pixels - i;
  std::memcpy(tail, in + 4 * i, rest * 4 * sizeof(std::uint16_t));
  run(tail, tail);
  std::memcpy(out + 4 * i, tail, rest * 4 * sizeof(std::uint16_t));
}

// Shaper tables (encode/grade/shaper.cpp) on whole buffers: the segment index is the float's
// exponent and top mantissa bits, so each value is two gathers and a lerp.
template <class D>
HWY_INLINE hn::Vec<D> EvalBitTable(D d, const detail::BitTableArgs& t, hn::Vec<D> x) {
  const hn::RebindToSigned<D> di;
  const hn::RebindToUnsigned<D> du;
  const auto u = hn::Mul(x, hn::Set(d, t.scale));
  const auto bits = hn::BitCast(du, u);
  auto idx = hn::Sub(hn::BitCast(di, hn::ShiftRightSame(bits, t.shift)), hn::Set(di, int(t.first_key)));
  idx = hn::Min(hn::Max(idx, hn::Zero(di)), hn::Set(di, int(t.count) - 2));
  const auto frac = hn::Mul(hn::ConvertTo(d, hn::BitCast(di, hn::And(bits, hn::Set(du, (1u << t.shift) - 1)))),
                            hn::Set(d, 1.0f / float(1u << t.shift)));
  const auto a = hn::GatherIndex(d, t.values, idx);
  const auto b = hn::GatherIndex(d, t.values + 1, idx);
  const auto inside = hn::MulAdd(hn::Sub(b, a), frac, a);
  const auto v0 = hn::Set(d, t.values[0]), z = hn::Set(d, t.at_zero);
  // NaN and negatives: Max(u, 0) is 0 on every target Highway maps Max to minps/maxps.
  const auto below = hn::MulAdd(hn::Sub(v0, z), hn::Div(hn::Max(u, hn::Zero(d)), hn::Set(d, t.lowest)), z);
  const auto lowest = hn::Set(d, t.lowest), one = hn::Set(d, 1.0f);
  return hn::IfThenElse(hn::Ge(u, one), hn::Set(d, t.at_one), hn::IfThenElse(hn::Gt(u, lowest), inside, below));
}

void BitTableRgba(const detail::BitTableArgs& t, float* HWY_RESTRICT rgba, std::size_t pixels) {
  const hn::ScalableTag<float> d;
  const std::size_t lanes = hn::Lanes(d);
  hn::Vec<decltype(d)> r, g, b, a;
  const auto run = [&](float* p) {
    hn::LoadInterleaved4(d, p, r, g, b, a);
    hn::StoreInterleaved4(EvalBitTable(d, t, r), EvalBitTable(d, t, g), EvalBitTable(d, t, b), a, d, p);
  };
  std::size_t i = 0;
  for (; i + lanes <= pixels; i += lanes) run(rgba + 4 * i);
  if (i == pixels) return;
  HWY_ALIGN float tail[4 * (HWY_MAX_BYTES / sizeof(float))] = {};
  std::memcpy(tail, rgba + 4 * i, (pixels - i) * 4 * sizeof(float));
  run(tail);
  std::memcpy(rgba + 4 * i, tail, (pixels - i) * 4 * sizeof(float));
}

}  // namespace hdrd::lut::HWY_NAMESPACE
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
#include <thread>

namespace hdrd::lut {

HWY_EXPORT(ApplyFloat);
HWY_EXPORT(ApplyHalf);
HWY_EXPORT(BitTableRgba);

void detail::bit_table_rgba(const BitTableArgs& t, float* rgba, std::size_t pixels) {
  HWY_DYNAMIC_DISPATCH(BitTableRgba)(t, rgba, pixels);
}

Applier3D::Applier3D(const Lut3D& lut, Interpolation interp) : size_(lut.size), interp_(interp) {
  const std::size_t entries = static_cast<std::size_t>(size_) * size_ * size_;
  // 4 floats per entry; +16 floats of slack so a full gather never reads past the end.
  table_.assign(entries * 4 + 16, 0.0f);
  for (std::size_t e = 0; e < entries; ++e)
    for (int c = 0; c < 3; ++c) table_[e * 4 + c] = lut.rgb[e * 3 + c];
  for (int c = 0; c < 3; ++c) {
    min_[c] = lut.domain.min[c];
    scale_[c] = float(size_ - 1) / (lut.domain.max[c] - lut.domain.min[c]);
  }
}

namespace {
detail::KernelArgs args_of(const std::vector<float>& table, int size, Interpolation interp,
                           const std::array<float, 3>& min, const std::array<float, 3>& scale) {
  detail::KernelArgs k{table.data(), size, interp == Interpolation::tetrahedral, {}, {}};
  for (int c = 0; c < 3; ++c) {
    k.min[c] = min[c];
    k.scale[c] = scale[c];
  }
  return k;
}
constexpr std::size_t kMinChunkPixels = 1 << 14;
}  // namespace

void Applier3D::apply(float* rgba, std::size_t pixels, int threads) const {
  const auto k = args_of(table_, size_, interp_, min_, scale_);
  parallel_for(pixels, threads, kMinChunkPixels, [&](std::size_t begin, std::size_t end) {
    HWY_DYNAMIC_DISPATCH(ApplyFloat)(k, rgba + 4 * begin, end - begin);
  });
}

void Applier3D::apply_half(const std::uint16_t* in, std::uint16_t* out, std::size_t pixels, int threads) const {
  const auto k = args_of(table_, size_, interp_, min_, scale_);
  parallel_for(pixels, threads, kMinChunkPixels, [&](std::size_t begin, std::size_t end) {
    HWY_DYNAMIC_DISPATCH(ApplyHalf)(k, in + 4 * begin, out + 4 * begin, end - begin);
  });
}

std::string simd_target_name() {
  const auto targets = hwy::SupportedAndGeneratedTargets();
  return targets.empty() ? "none" : hwy::TargetName(targets.front());
}


}  // namespace hdrd::lut
#endif  // HWY_ONCE
