// Highway dynamic dispatch: this file is compiled once per SIMD target.
#undef HWY_TARGET_INCLUDE
#define HWY_TARGET_INCLUDE "encode/kernel/fast_fused.cpp"
#include <hwy/foreach_target.h>  // IWYU pragma: keep
#include <hwy/cache_control.h>
#include <hwy/highway.h>

#include <algorithm>
#include <bit>
#include <cstring>

#include "encode/kernel/constants.hpp"
#include "encode/kernel/fast_fused.hpp"
#include "encode/kernel/float_lut.hpp"
#include "encode/kernel/half-inl.h"

HWY_BEFORE_NAMESPACE();
namespace hdrd::kernels {
namespace HWY_NAMESPACE {
namespace hn = hwy::HWY_NAMESPACE;

using DF = hn::ScalableTag<float>;
using DU = hn::RebindToUnsigned<DF>;
using DI = hn::RebindToSigned<DF>;
using VF = hn::Vec<DF>;

HWY_INLINE VF lut(DF df, const LutView& l, VF v);

// ToneStage's lookup with a toe (pipeline_internal.hpp toe_lookup): below the table's
// bottom the straight line from f(0); v >= 0.
HWY_INLINE VF toe_lut(DF df, const LutView& l, float zero, float slope, VF v) {
  const VF toe = hn::MulAdd(v, hn::Set(df, slope), hn::Set(df, zero));
  return hn::IfThenElse(hn::Lt(v, hn::Set(df, l.lo)), toe, lut(df, l, v));
}

// FloatBitsLut::operator() for a vector: clamp into [lo, hi), index from the float's bits,
// linear interpolation inside the bucket, and the hats of the kinks in it (rare: one
// compare per kink decides that no lane needs them).
HWY_INLINE VF lut(DF df, const LutView& l, VF v) {
  const DU du;
  const DI di;
  constexpr int kShift = FloatBitsLut::kShift;
  v = hn::Min(hn::Max(v, hn::Set(df, l.lo)), hn::Set(df, l.hi_prev));
  const auto rel = hn::Sub(hn::BitCast(du, v), hn::Set(du, l.base_bits));
  const auto idx = hn::BitCast(di, hn::ShiftRight<kShift>(rel));
  const VF frac = hn::Mul(hn::ConvertTo(df, hn::BitCast(di, hn::And(rel, hn::Set(du, (1u << kShift) - 1)))),
                          hn::Set(df, 1.0f / (1u << kShift)));
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  // Both ends of each bucket with one 64-bit load per lane (half the gathered elements),
  // then the (value, step) pairs unzipped.
  const __m512i i32 = idx.raw;
  const __m512 lo8 = _mm512_castsi512_ps(_mm512_i32gather_epi64(_mm512_castsi512_si256(i32), l.pairs, 8));
  const __m512 hi8 = _mm512_castsi512_ps(_mm512_i32gather_epi64(_mm512_extracti64x4_epi64(i32, 1), l.pairs, 8));
  const __m512i even = _mm512_set_epi32(30, 28, 26, 24, 22, 20, 18, 16, 14, 12, 10, 8, 6, 4, 2, 0);
  const __m512i odd = _mm512_set_epi32(31, 29, 27, 25, 23, 21, 19, 17, 15, 13, 11, 9, 7, 5, 3, 1);
  const VF a{_mm512_permutex2var_ps(lo8, even, hi8)};
  const VF step{_mm512_permutex2var_ps(lo8, odd, hi8)};
  VF r = hn::MulAdd(step, frac, a);
#else
  const VF a = hn::GatherIndex(df, l.table, idx);
  const VF b = hn::GatherIndex(df, l.table + 1, idx);
  VF r = hn::MulAdd(hn::Sub(b, a), frac, a);
#endif
  if (l.patch_count == 0) return r;
  auto any = hn::Eq(idx, hn::Set(di, static_cast<std::int32_t>(l.patches[0].bucket)));
  for (int j = 1; j < l.patch_count; ++j)
    any = hn::Or(any, hn::Eq(idx, hn::Set(di, static_cast<std::int32_t>(l.patches[j].bucket))));
  if (hn::AllFalse(di, any)) return r;
  for (int j = 0; j < l.patch_count; ++j) {
    const FloatBitsLut::Patch& p = l.patches[j];
    const auto in = hn::RebindMask(df, hn::Eq(idx, hn::Set(di, static_cast<std::int32_t>(p.bucket))));
    const VF up = hn::Mul(hn::Sub(frac, hn::Set(df, p.left)), hn::Set(df, p.inv_left));
    const VF down = hn::Mul(hn::Sub(hn::Set(df, p.right), frac), hn::Set(df, p.inv_right));
    const VF hat = hn::Max(hn::Zero(df), hn::Min(up, down));
    r = hn::IfThenElse(in, hn::MulAdd(hat, hn::Set(df, p.delta), r), r);
  }
  return r;
}

HWY_INLINE VF signal(DF df, const FusedRow& r, VF v) { return lut(df, r.signal, v); }

// FloatBitsQuantizer::code for a vector: the bucket's code, plus one past the bucket's
// last position with that code. Negative input (and the default NaN, whose sign bit is
// set) lands in the first bucket; the constants are made once. `kBelowTop`: the caller
// guarantees no input lies above the table (or is a positive NaN), so the upper clamp goes.
struct Quantizer {
  explicit Quantizer(const QuantView& q)
      // Indexed by bits >> shift straight: the table's start moved back by the first
      // bucket's index (bits below it are clamped up to it first).
      : table(reinterpret_cast<const std::int32_t*>(reinterpret_cast<std::uintptr_t>(q.table) -
                                                    (q.base_bits >> q.shift) * sizeof(std::uint32_t))),
        lo_bits(hn::Set(DI(), static_cast<std::int32_t>(q.base_bits))),
        hi_bits(hn::Set(DI(), static_cast<std::int32_t>(q.base_bits + q.top_rel))),
        code_mask(hn::Set(DU(), (1u << (32 - q.shift)) - 1)),
        one(hn::Set(DU(), 1)),
        shift(hn::Set(DU(), static_cast<std::uint32_t>(q.shift))),
        low_shift(hn::Set(DU(), static_cast<std::uint32_t>(32 - q.shift))) {}

  template <bool kBelowTop>
  HWY_INLINE hn::Vec<DI> code(VF v) const {
    const DI di;
    const DU du;
    // Positive floats order as their bits; negative ones are negative as int32 (-> the first bucket).
    auto clamped = hn::Max(hn::BitCast(di, v), lo_bits);
    if (!kBelowTop) clamped = hn::Min(clamped, hi_bits);
    const auto bits = hn::BitCast(du, clamped);
    const auto e = hn::BitCast(du, hn::GatherIndex(di, table, hn::BitCast(di, bits >> shift)));
    // The position inside the bucket, moved to the top: above the entry exactly when past
    // the bucket's last position with the entry's code (float_lut.hpp).
    const auto low_at_top = bits << low_shift;
    const auto code = hn::And(e, code_mask);
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
    return hn::BitCast(di, hn::Vec<DU>{_mm512_mask_add_epi32(code.raw, _mm512_cmpgt_epu32_mask(low_at_top.raw, e.raw),
                                                              code.raw, one.raw)});
#else
    return hn::BitCast(di, hn::IfThenElse(hn::Gt(low_at_top, e), hn::Add(code, one), code));
#endif
  }

  const std::int32_t* table;
  hn::Vec<DI> lo_bits, hi_bits;
  hn::Vec<DU> code_mask, one, shift, low_shift;
};

// Decoded light of codes for MaxFALL: on AVX-512 the per-32-code quartic in code % 32
// (five two-table permutes instead of a 16-lane gather); elsewhere, and for MaxCLL, the
// table itself.
struct CodeLight {
  explicit CodeLight(const FusedRow& r) : table(r.code_to_nits), poly(r.code_nits_poly) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
    if (poly)
      for (int i = 0; i < 5; ++i) {
        lo[i] = _mm512_loadu_ps(poly + 32 * i);
        hi[i] = _mm512_loadu_ps(poly + 32 * i + 16);
      }
#endif
  }

  HWY_INLINE VF operator()(DF df, hn::Vec<DI> code) const {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
    if (poly) {
      const DI di;
      const __m512i seg = hn::ShiftRight<5>(code).raw;
      const VF t = hn::ConvertTo(df, hn::And(code, hn::Set(di, 31)));
      VF v{_mm512_permutex2var_ps(lo[4], seg, hi[4])};
      for (int i = 3; i >= 0; --i) v = hn::MulAdd(v, t, VF{_mm512_permutex2var_ps(lo[i], seg, hi[i])});
      // The fit is within 1e-3 cd/m2 of the table, but may dip below 0 near code 0 (black
      // read -1.3e-5 cd/m2): light is never negative, so MaxFALL never is.
      return hn::Max(v, hn::Zero(df));
    }
#endif
    return hn::GatherIndex(df, table, code);
  }

  const float* table;
  const float* poly;
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  __m512 lo[5], hi[5];
#endif
};

HWY_INLINE VF sanitize(DF df, VF v) {
  const VF c = hn::Min(hn::Max(v, hn::Set(df, -1e30f)), hn::Set(df, 1e30f));
  return hn::IfThenElseZero(hn::Eq(v, v), c);  // NaN -> 0
}

// What shapes a row's loops: fixed at compile time for the common HDR10 frame (half
// input, ratio of max(RGB) into a Rec.2020 container, exact codes, MaxFALL), read from the
// row otherwise. The fixed instance has no per-vector tests of the row's options.
struct RuntimeSpec {
  const FusedRow* r;
  bool half() const { return r->half_in != nullptr; }
  FusedTone tone() const { return r->tone; }
  bool container() const { return r->m_container != nullptr; }
  bool gamut() const { return r->gamut_check; }
  FusedOut out() const { return r->out_kind; }
  bool quant() const { return r->codes.table != nullptr; }
  bool cll() const { return r->code_to_nits != nullptr; }
  bool signal16() const { return r->signal16 != nullptr; }
  bool lift() const { return r->lift.table != nullptr; }
  bool display() const { return r->display != nullptr; }
  static constexpr bool below_top() { return false; }
};

struct Hdr10Spec {
  static constexpr bool half() { return true; }
  static constexpr FusedTone tone() { return FusedTone::ratio_max; }
  static constexpr bool container() { return false; }
  static constexpr bool gamut() { return false; }
  static constexpr FusedOut out() { return FusedOut::packed10; }
  static constexpr bool quant() { return true; }
  static constexpr bool cll() { return true; }
  static constexpr bool signal16() { return false; }
  static constexpr bool lift() { return false; }
  static constexpr bool display() { return false; }
  // No code input lies above the quantiser's table, so its upper clamp goes: the ratio of
  // max(RGB) keeps each channel at or below the peak (the curves never pass it:
  // tonemap_test; 0.1 % covers the table's interpolation), and the UI adds at most ui_max.
  static constexpr bool below_top() { return true; }
  static bool matches(const FusedRow& r) {
    const RuntimeSpec s{&r};
    if (!(s.half() == half() && s.tone() == tone() && s.container() == container() && s.gamut() == gamut() &&
          s.out() == out() && s.quant() == quant() && s.cll() == cll() && s.signal16() == signal16() &&
          s.lift() == lift() && s.display() == display()))
      return false;
    const float top = std::bit_cast<float>(r.codes.base_bits + r.codes.top_rel);
    return r.peak * 1.001f + (r.ui ? r.ui_max : 0.0f) < top;
  }
};

template <class Spec>
HWY_INLINE void load_rgb(DF df, const Spec& spec, const FusedRow& r, int x, VF& R, VF& G, VF& B) {
  if (spec.half()) {
#if HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
    // 16 RGBA half pixels are two vectors; one word permute per channel gathers its 16 values.
    const __m512i lo = _mm512_loadu_si512(r.half_in + static_cast<std::size_t>(x) * 4);
    const __m512i hi = _mm512_loadu_si512(r.half_in + static_cast<std::size_t>(x) * 4 + 32);
    const __m512i ir = _mm512_set_epi16(0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 60, 56, 52, 48, 44, 40,
                                        36, 32, 28, 24, 20, 16, 12, 8, 4, 0);
    const __m512i one = _mm512_set1_epi16(1);
    const __m512i ig = _mm512_add_epi16(ir, one), ib = _mm512_add_epi16(ig, one);
    R = VF{_mm512_cvtph_ps(_mm512_castsi512_si256(_mm512_permutex2var_epi16(lo, ir, hi)))};
    G = VF{_mm512_cvtph_ps(_mm512_castsi512_si256(_mm512_permutex2var_epi16(lo, ig, hi)))};
    B = VF{_mm512_cvtph_ps(_mm512_castsi512_si256(_mm512_permutex2var_epi16(lo, ib, hi)))};
#else
    const hn::Rebind<std::uint16_t, DF> du16;
    hn::Vec<decltype(du16)> r16, g16, b16, a16;
    hn::LoadInterleaved4(du16, r.half_in + static_cast<std::size_t>(x) * 4, r16, g16, b16, a16);
    R = half_to_float(df, r16), G = half_to_float(df, g16), B = half_to_float(df, b16);
#endif
  } else {
    VF a;
    hn::LoadInterleaved4(df, r.float_in + static_cast<std::size_t>(x) * 4, R, G, B, a);
  }
}

// A 3x3 matrix as nine splatted vectors, made once per row: in the loop each coefficient
// is a register or a full-vector memory operand, never a broadcast on the shuffle port.
struct MatV {
  MatV() = default;
  explicit MatV(const float* m) {
    for (int i = 0; i < 9; ++i) v[i] = hn::Set(DF(), m ? m[i] : 0.0f);
  }
  VF v[9];
};

HWY_INLINE void matrix(const MatV& m, VF& r, VF& g, VF& b) {
  const VF x = r, y = g, z = b;
  r = hn::MulAdd(m.v[0], x, hn::MulAdd(m.v[1], y, hn::Mul(m.v[2], z)));
  g = hn::MulAdd(m.v[3], x, hn::MulAdd(m.v[4], y, hn::Mul(m.v[5], z)));
  b = hn::MulAdd(m.v[6], x, hn::MulAdd(m.v[7], y, hn::Mul(m.v[8], z)));
}

template <class Spec>
HWY_INLINE void tone(DF df, const Spec& spec, const FusedRow& r, const MatV& m_container, VF& R, VF& G, VF& B) {
  const VF zero = hn::Zero(df);
  R = hn::Max(R, zero), G = hn::Max(G, zero), B = hn::Max(B, zero);
  switch (spec.tone()) {
    case FusedTone::clip: {
      const VF pw = hn::Set(df, r.paper_white), pk = hn::Set(df, r.peak);
      R = hn::Min(hn::Mul(R, pw), pk), G = hn::Min(hn::Mul(G, pw), pk), B = hn::Min(hn::Mul(B, pw), pk);
      break;
    }
    case FusedTone::per_channel:
      R = toe_lut(df, r.tone_lut, r.tone_zero, r.tone_toe_slope, R);
      G = toe_lut(df, r.tone_lut, r.tone_zero, r.tone_toe_slope, G);
      B = toe_lut(df, r.tone_lut, r.tone_zero, r.tone_toe_slope, B);
      break;
    default: {
      VF k = spec.tone() == FusedTone::ratio_max
                       ? hn::Max(hn::Max(R, G), B)
                       : hn::MulAdd(hn::Set(df, kernel::kLumaR), R,
                                    hn::MulAdd(hn::Set(df, kernel::kLumaG), G, hn::Mul(hn::Set(df, kernel::kLumaB), B)));
      if (spec.tone() == FusedTone::ratio_max && spec.container()) {
        // The largest channel in the output container too, so no output channel passes the peak.
        VF cr = R, cg = G, cb = B;
        matrix(m_container, cr, cg, cb);
        k = hn::Max(k, hn::Max(hn::Max(cr, cg), cb));
      }
      // k >= 0; at 0 the table's bottom ratio leaves the black pixel black.
      VF ratio;
      if (hn::AllTrue(df, hn::Lt(k, hn::Set(df, r.tone_lut.flat_below)))) {
        // All below the curve's knee, where the ratio table is flat (a curve linear there,
        // such as pq-shoulder up to its knee): the lookup's exact result, with no gather.
        ratio = hn::Set(df, r.tone_lut.table[0]);
      } else {
        ratio = lut(df, r.tone_lut, k);
        // Above the table: the curve's value at the top, spread over k (saturates at the
        // peak). Rare (2^20 x paper white), so the division stays off the common path.
        const VF top = hn::Set(df, r.tone_lut.hi);
        if (!hn::AllFalse(df, hn::Gt(k, top))) ratio = hn::Mul(ratio, hn::Min(hn::Set(df, 1.0f), hn::Div(top, k)));
      }
      R = hn::Mul(R, ratio), G = hn::Mul(G, ratio), B = hn::Mul(B, ratio);
      if (spec.lift()) {
        R = toe_lut(df, r.lift, r.lift_zero, r.lift_toe_slope, R);
        G = toe_lut(df, r.lift, r.lift_zero, r.lift_toe_slope, G);
        B = toe_lut(df, r.lift, r.lift_zero, r.lift_toe_slope, B);
      }
    }
  }
}

// Container light of pixels [x, x + N) (tone, container matrix, UI), with the mask of
// those that stayed inside the display gamut (the rest are listed for the exact path).
struct RowMats {
  explicit RowMats(const FusedRow& r) : in(r.m_in), container(r.m_container) {}
  MatV in, container;
};

// Asks for the input kPrefetchAhead bytes past pixel x, a cache line at a time. The
// hardware prefetcher alone keeps too few lines in flight for one core's share of the
// memory bandwidth: measured 6-9 % faster at 1 and 2 threads (2 to 8 KiB ahead alike).
// The address may lie past the buffer: a prefetch never faults, and it is formed as an
// integer, not as a pointer past the array.
template <class Spec>
HWY_INLINE void prefetch_input(DF df, const Spec& spec, const FusedRow& r, int x) {
  constexpr std::uintptr_t kPrefetchAhead = 4096, kLine = 64;
  const std::uintptr_t at = spec.half() ? reinterpret_cast<std::uintptr_t>(r.half_in + static_cast<std::size_t>(x) * 4)
                                        : reinterpret_cast<std::uintptr_t>(r.float_in + static_cast<std::size_t>(x) * 4);
  const std::uintptr_t bytes = hn::Lanes(df) * (spec.half() ? 8 : 16);
  for (std::uintptr_t o = 0; o < bytes; o += kLine) hwy::Prefetch(reinterpret_cast<const char*>(at + kPrefetchAhead + o));
}

template <class Spec>
HWY_INLINE hn::Mask<DF> container_light(DF df, const Spec& spec, FusedRow& r, const RowMats& m, int x, VF& R, VF& G,
                                        VF& B, VF& work_max) {
  const int N = static_cast<int>(hn::Lanes(df));
  prefetch_input(df, spec, r, x);
  load_rgb(df, spec, r, x, R, G, B);
  // Finite halves are far inside +-1e30: only NaN and Inf need the documented rule.
  if (!spec.half() || !hn::AllTrue(df, hn::IsFinite(hn::Add(hn::Add(R, G), B))))
    R = sanitize(df, R), G = sanitize(df, G), B = sanitize(df, B);
  matrix(m.in, R, G, B);
  tone(df, spec, r, m.container, R, G, B);
  work_max = hn::Max(hn::Max(R, G), B);  // Rec.2020 nits: the CLL of scRGB
  if (spec.container()) matrix(m.container, R, G, B);
  auto ok = hn::FirstN(df, N);
  if (spec.gamut()) {
    const VF lo = hn::Set(df, r.gamut_lo), hi = hn::Set(df, r.gamut_hi);
    ok = hn::And(hn::And(hn::And(hn::Ge(R, lo), hn::Ge(G, lo)), hn::And(hn::Ge(B, lo), hn::Le(R, hi))),
                 hn::And(hn::Le(G, hi), hn::Le(B, hi)));
  }
  if (spec.gamut() && !hn::AllTrue(df, ok)) {
    alignas(64) float okf[64];
    hn::Store(hn::IfThenElseZero(ok, hn::Set(df, 1.0f)), df, okf);
    for (int i = 0; i < N; ++i)
      if (okf[i] == 0.0f) r.fallback[r.fallback_count++] = x + i;
  }
  if (r.ui) {
    VF ur, ug, ub, keep;
    hn::LoadInterleaved4(df, r.ui + static_cast<std::size_t>(x) * 4, ur, ug, ub, keep);
    R = hn::MulAdd(R, keep, ur), G = hn::MulAdd(G, keep, ug), B = hn::MulAdd(B, keep, ub);
    if (r.ui_max > r.peak) {
      const VF pk = hn::Set(df, r.peak);
      R = hn::Min(R, pk), G = hn::Min(G, pk), B = hn::Min(B, pk);
    }
  }
  return ok;
}

// The kernel works on a local copy of the row's parameters: stores to the output cannot
// alias it, so loop-invariant fields need not be reloaded per vector.
template <class Spec>
HWY_INLINE void FusedRowLocal(const Spec& spec, FusedRow& r) {
  const DF df;
  const DU du;
  const DI di;
  const int N = static_cast<int>(hn::Lanes(df));
  const VF scale = hn::Set(df, r.code_scale), bias = hn::Set(df, r.code_offset + 0.5f);
  const auto max_code = hn::Set(di, r.max_code);
  auto vmax = hn::Zero(df);
  auto vsum = hn::Zero(df);  // per-lane sums of at most n / N values: float is enough
  const RowMats mats(r);
  const int n_full = r.n - r.n % N;

  if (spec.out() == FusedOut::scrgb) {
    const hn::Rebind<std::uint16_t, DF> du16;
    const hn::Rebind<hwy::float16_t, DF> dh;
    const VF k80 = hn::Set(df, kernel::kInvScrgbUnitNits);
    for (int x = 0; x < n_full; x += N) {
      VF R, G, B, work_max;
      const auto ok = container_light(df, spec, r, mats, x, R, G, B, work_max);
      const auto h_r = hn::BitCast(du16, hn::DemoteTo(dh, hn::Mul(R, k80)));
      const auto h_g = hn::BitCast(du16, hn::DemoteTo(dh, hn::Mul(G, k80)));
      const auto h_b = hn::BitCast(du16, hn::DemoteTo(dh, hn::Mul(B, k80)));
      hn::StoreInterleaved4(h_r, h_g, h_b, hn::Set(du16, 0x3C00), du16,
                            reinterpret_cast<std::uint16_t*>(r.out) + static_cast<std::size_t>(x) * 4);
      if (spec.display()) hn::StoreInterleaved4(R, G, B, hn::Set(df, 1.0f), df, r.display + static_cast<std::size_t>(x) * 4);
      const VF m = hn::IfThenElseZero(ok, work_max);
      vmax = hn::Max(vmax, m);
      vsum = hn::Add(vsum, m);
    }
  } else {
    // Passes per L1-sized chunk: light, then signal and codes, then (HDR10) the light of
    // each pixel's largest code. Each pass is a shorter dependency chain than the whole
    // (tone gathers, quantiser gathers, the content-light decode), so more iterations
    // overlap in the out-of-order window, and the last one keeps its decode tables in
    // registers (3 % faster than decoding in the codes pass). kChunk is a multiple of
    // every target's lane count.
    const Quantizer quantize(r.codes);
    const CodeLight code_light(r);
    auto vmax_code = hn::Zero(di);
    constexpr int kChunk = 512;
    alignas(64) float buf_r[kChunk], buf_g[kChunk], buf_b[kChunk], buf_ok[kChunk];
    alignas(64) std::int32_t buf_code[kChunk];
    const VF one = hn::Set(df, 1.0f), zero = hn::Zero(df);
    for (int x0 = 0; x0 < n_full; x0 += kChunk) {
      const int x1 = std::min(n_full, x0 + kChunk);
      for (int x = x0; x < x1; x += N) {
        VF R, G, B, work_max;
        const auto ok = container_light(df, spec, r, mats, x, R, G, B, work_max);
        hn::Store(R, df, buf_r + (x - x0));
        hn::Store(G, df, buf_g + (x - x0));
        hn::Store(B, df, buf_b + (x - x0));
        if (spec.gamut()) hn::Store(hn::IfThenElseZero(ok, one), df, buf_ok + (x - x0));
        if (spec.display()) {
          // What the staged path's to_volume leaves (the pixels listed for the exact path
          // are overwritten by it).
          const VF lo = hn::Set(df, r.display_lo), hi = hn::Set(df, r.display_hi);
          auto shown = [&](VF v) { return hn::Min(hn::Max(v, lo), hi); };
          hn::StoreInterleaved4(shown(R), shown(G), shown(B), one, df, r.display + static_cast<std::size_t>(x) * 4);
        }
      }
      for (int x = x0; x < x1; x += N) {
        const VF R = hn::Load(df, buf_r + (x - x0)), G = hn::Load(df, buf_g + (x - x0)), B = hn::Load(df, buf_b + (x - x0));
        // Codes: exact from the quantiser's table, or round(E' scale + offset) from the
        // signal table (full: scale 2^n - 1; narrow: 219 2^(n-8), offset 16 2^(n-8)).
        auto e_of = [&](VF v) { return hn::Min(hn::Max(signal(df, r, v), zero), one); };
        auto code_of = [&](VF e) { return hn::Min(hn::ConvertTo(di, hn::MulAdd(e, scale, bias)), max_code); };
        hn::Vec<DI> cr, cg, cb;
        if (spec.quant()) {
          constexpr bool kBelowTop = Spec::below_top();
          cr = quantize.code<kBelowTop>(R), cg = quantize.code<kBelowTop>(G), cb = quantize.code<kBelowTop>(B);
        } else {
          cr = code_of(e_of(R)), cg = code_of(e_of(G)), cb = code_of(e_of(B));
        }
        auto* out32 = reinterpret_cast<std::uint32_t*>(r.out) + x;
        if (spec.out() == FusedOut::xrgb8) {
          const auto w = hn::Or(hn::Or(hn::BitCast(du, cb), hn::ShiftLeft<8>(hn::BitCast(du, cg))),
                                hn::Or(hn::ShiftLeft<16>(hn::BitCast(du, cr)), hn::Set(du, 0xFF000000u)));
          hn::StoreU(w, du, out32);
          continue;
        }
        const auto w = hn::Or(hn::Or(hn::BitCast(du, cr), hn::ShiftLeft<10>(hn::BitCast(du, cg))),
                              hn::Or(hn::ShiftLeft<20>(hn::BitCast(du, cb)), hn::Set(du, 3u << 30)));
        hn::StoreU(w, du, out32);
        if (spec.signal16()) {
          // PNG samples: round(E' 65535), or the narrow code scaled to 16 bits.
          const hn::Rebind<std::uint16_t, DF> du16;
          const VF k16 = hn::Set(df, kernel::kMax16), half = hn::Set(df, 0.5f);
          auto s16 = [&](VF v, hn::Vec<DI> c) {
            const VF u = r.narrow ? hn::MulAdd(hn::ConvertTo(df, c), hn::Set(df, kernel::kCode10To16), half)
                                  : hn::MulAdd(hn::Min(e_of(v), hn::Set(df, r.signal_max)), k16, half);
            return hn::DemoteTo(du16, hn::ConvertTo(di, u));
          };
          hn::StoreInterleaved3(s16(R, cr), s16(G, cg), s16(B, cb), du16,
                                r.signal16 + static_cast<std::size_t>(x) * 3);
        }
        if (spec.cll()) {
          // MaxCLL from the largest code (decoded once, below), MaxFALL from each pixel's.
          auto cmax = hn::Max(hn::Max(cr, cg), cb);
          if (spec.gamut())  // pixels left for the exact path are counted there
            cmax = hn::IfThenElseZero(hn::RebindMask(di, hn::Ne(hn::Load(df, buf_ok + (x - x0)), zero)), cmax);
          vmax_code = hn::Max(vmax_code, cmax);
          hn::Store(cmax, di, buf_code + (x - x0));
        }
      }
      if (spec.cll())
        for (int x = x0; x < x1; x += N) vsum = hn::Add(vsum, code_light(df, hn::Load(di, buf_code + (x - x0))));
    }
    if (spec.cll())
      r.max_nits = std::max<double>(r.max_nits, r.code_to_nits[hn::GetLane(hn::MaxOfLanes(di, vmax_code))]);
  }
  r.done = n_full;
  r.max_nits = std::max<double>(r.max_nits, hn::GetLane(hn::MaxOfLanes(df, vmax)));
  r.sum_nits += hn::GetLane(hn::SumOfLanes(df, vsum));
}

void FusedRowImpl(FusedRow& row) {
  FusedRow r = row;
  if (Hdr10Spec::matches(r)) FusedRowLocal(Hdr10Spec(), r);
  else FusedRowLocal(RuntimeSpec{&r}, r);
  row = r;
}

}  // namespace HWY_NAMESPACE
}  // namespace hdrd::kernels
HWY_AFTER_NAMESPACE();

#if HWY_ONCE
namespace hdrd::kernels {
HWY_EXPORT(FusedRowImpl);
void fused_row(FusedRow& r) { HWY_DYNAMIC_DISPATCH(FusedRowImpl)(r); }
}  // namespace hdrd::kernels
#endif
