// IEEE half -> float for the SIMD kernels (fast_fused.cpp, light_kernels.cpp), included
// inside each Highway target's namespace (the -inl.h convention: once per target).
// F16C where the target has it; elsewhere by bits, because Highway's emulation turns NaN
// and Inf into finite values (and the documented rule treats them differently).
#if defined(HDRD_ENCODE_KERNEL_HALF_INL_H_) == defined(HWY_TARGET_TOGGLE)
#ifdef HDRD_ENCODE_KERNEL_HALF_INL_H_
#undef HDRD_ENCODE_KERNEL_HALF_INL_H_
#else
#define HDRD_ENCODE_KERNEL_HALF_INL_H_
#endif

#include <hwy/highway.h>

HWY_BEFORE_NAMESPACE();
namespace hdrd::kernels {
namespace HWY_NAMESPACE {

// h16: the halves' bits, one per lane of df (a u16 vector of df's lane count).
template <class DF, class VU16>
HWY_INLINE hwy::HWY_NAMESPACE::Vec<DF> half_to_float(DF df, VU16 h16) {
  namespace hn = hwy::HWY_NAMESPACE;
#if HWY_TARGET == HWY_AVX2 || HWY_TARGET == HWY_AVX3 || HWY_TARGET == HWY_AVX3_DL
  return hn::PromoteTo(df, hn::BitCast(hn::Rebind<hwy::float16_t, DF>(), h16));
#else
  const hn::RebindToUnsigned<DF> du;
  const hn::RebindToSigned<DF> di;
  const auto h = hn::PromoteTo(du, h16);
  const auto mag = hn::And(h, hn::Set(du, 0x7FFFu));
  // Normal and subnormal halves: the bits moved into place, rescaled by 2^(127 - 15).
  auto f = hn::Mul(hn::BitCast(df, hn::ShiftLeft<13>(mag)), hn::Set(df, 5.192296858534828e33f));
  const auto inf_nan = hn::Gt(hn::BitCast(di, mag), hn::Set(di, 0x7BFF));
  f = hn::IfThenElse(hn::RebindMask(df, inf_nan),
                     hn::BitCast(df, hn::Or(hn::ShiftLeft<13>(mag), hn::Set(du, 0x7F800000u))), f);
  return hn::Or(f, hn::BitCast(df, hn::ShiftLeft<16>(hn::And(h, hn::Set(du, 0x8000u)))));
#endif
}

}  // namespace HWY_NAMESPACE
}  // namespace hdrd::kernels
HWY_AFTER_NAMESPACE();

#endif  // HDRD_ENCODE_KERNEL_HALF_INL_H_
