//! The arithmetic of the contact formulas, written once for scalars (`f64`) and for four
//! contacts at a time in SIMD lanes (`wide::f64x4`): branches become lane masks.
use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Mul, Neg, Sub};

use wide::{f64x4, CmpGt, CmpLe, CmpLt};

pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
{
    /// The outcome of a comparison, one flag per lane.
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask>;
    fn sqrt(self) -> Self;
    fn splat(x: f64) -> Self;
    fn lt(self, other: Self) -> Self::Mask;
    fn le(self, other: Self) -> Self::Mask;
    fn gt(self, other: Self) -> Self::Mask;
    /// `yes` in the lanes where `mask` is set, else `no`.
    fn select(mask: Self::Mask, yes: Self, no: Self) -> Self;
    fn max(self, other: Self) -> Self;
    /// Whether no lane of `mask` is set.
    fn none(mask: Self::Mask) -> bool;
    /// `f` applied lane by lane (for the rare scalar-only steps, e.g. a cube root).
    fn map(self, f: impl Fn(f64) -> f64) -> Self;
    /// Lanes built from a function of the lane index.
    fn from_lanes(f: impl Fn(usize) -> f64) -> Self;
    /// Lane `l`.
    fn lane(self, l: usize) -> f64;
}

impl Real for f64 {
    type Mask = bool;
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn lt(self, other: Self) -> bool {
        self < other
    }
    #[inline(always)]
    fn le(self, other: Self) -> bool {
        self <= other
    }
    #[inline(always)]
    fn gt(self, other: Self) -> bool {
        self > other
    }
    #[inline(always)]
    fn select(mask: bool, yes: Self, no: Self) -> Self {
        if mask {
            yes
        } else {
            no
        }
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f64::max(self, other)
    }
    #[inline(always)]
    fn none(mask: bool) -> bool {
        !mask
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        f(self)
    }
    #[inline(always)]
    fn from_lanes(f: impl Fn(usize) -> f64) -> Self {
        f(0)
    }
    #[inline(always)]
    fn lane(self, _: usize) -> f64 {
        self
    }
}

impl Real for f64x4 {
    type Mask = f64x4;
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64x4::sqrt(self)
    }
    #[inline(always)]
    fn splat(x: f64) -> Self {
        f64x4::splat(x)
    }
    #[inline(always)]
    fn lt(self, other: Self) -> Self {
        self.cmp_lt(other)
    }
    #[inline(always)]
    fn le(self, other: Self) -> Self {
        self.cmp_le(other)
    }
    #[inline(always)]
    fn gt(self, other: Self) -> Self {
        self.cmp_gt(other)
    }
    #[inline(always)]
    fn select(mask: Self, yes: Self, no: Self) -> Self {
        mask.blend(yes, no)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        f64x4::max(self, other)
    }
    #[inline(always)]
    fn none(mask: Self) -> bool {
        mask.none()
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        f64x4::new(self.to_array().map(f))
    }
    #[inline(always)]
    fn from_lanes(f: impl Fn(usize) -> f64) -> Self {
        f64x4::new([f(0), f(1), f(2), f(3)])
    }
    #[inline(always)]
    fn lane(self, l: usize) -> f64 {
        self.to_array()[l]
    }
}

/// A vector of three `Real`s: one 3-vector, or one per lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct V3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

impl<T: Real> V3<T> {
    #[inline(always)]
    pub fn new(x: T, y: T, z: T) -> Self {
        Self { x, y, z }
    }
    #[inline(always)]
    pub fn zero() -> Self {
        let z = T::splat(0.0);
        Self::new(z, z, z)
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    #[inline(always)]
    pub fn length(self) -> T {
        self.dot(self).sqrt()
    }
    #[inline(always)]
    pub fn scale(self, s: T) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }
    /// `self` in the lanes of `mask`, else `other`.
    #[inline(always)]
    pub fn select(mask: T::Mask, yes: Self, no: Self) -> Self {
        Self::new(
            T::select(mask, yes.x, no.x),
            T::select(mask, yes.y, no.y),
            T::select(mask, yes.z, no.z),
        )
    }
}

impl<T: Real> Add for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl<T: Real> AddAssign for V3<T> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl<T: Real> Sub for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl<T: Real> Neg for V3<T> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

/// The 4 x 4 transpose: lane `l` of output `k` is lane `k` of input `l` (exact: it only
/// moves values). With AVX, eight shuffles in registers.
#[inline(always)]
pub fn transpose4(rows: [f64x4; 4]) -> [f64x4; 4] {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
    {
        use std::arch::x86_64::{
            __m256d, _mm256_permute2f128_pd, _mm256_unpackhi_pd, _mm256_unpacklo_pd,
        };
        // SAFETY: f64x4 and __m256d are both four f64 in 32 bytes (wide builds f64x4 on
        // __m256d with AVX), and the intrinsics need only AVX, enabled for this build.
        unsafe {
            let [a, b, c, d]: [__m256d; 4] = std::mem::transmute(rows);
            let (ab_lo, ab_hi) = (_mm256_unpacklo_pd(a, b), _mm256_unpackhi_pd(a, b));
            let (cd_lo, cd_hi) = (_mm256_unpacklo_pd(c, d), _mm256_unpackhi_pd(c, d));
            std::mem::transmute::<[__m256d; 4], [f64x4; 4]>([
                _mm256_permute2f128_pd(ab_lo, cd_lo, 0x20),
                _mm256_permute2f128_pd(ab_hi, cd_hi, 0x20),
                _mm256_permute2f128_pd(ab_lo, cd_lo, 0x31),
                _mm256_permute2f128_pd(ab_hi, cd_hi, 0x31),
            ])
        }
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
    {
        let a = rows.map(|r| r.to_array());
        [0, 1, 2, 3].map(|k| f64x4::new([a[0][k], a[1][k], a[2][k], a[3][k]]))
    }
}

/// Gather `col[js[0..4]]` into lanes.
#[inline(always)]
pub fn gather(col: &[f64], js: &[usize; 4]) -> f64x4 {
    f64x4::new([col[js[0]], col[js[1]], col[js[2]], col[js[3]]])
}

/// Lane masks of a group of 1, 2, 3 or 4 pairs: `group_masks()[m - 1]` sets lanes `< m`.
#[inline(always)]
pub fn group_masks() -> [f64x4; 4] {
    let zero = f64x4::ZERO;
    [1, 2, 3, 4]
        .map(|m| f64x4::new([0, 1, 2, 3].map(|l| if l < m { 1.0 } else { -1.0 })).cmp_gt(zero))
}

/// The first `out.len()` (1 to 4) lanes of `v` into `out`, with fixed-size stores (a
/// copy of variable length would call `memcpy`).
#[inline(always)]
pub fn store_lanes(out: &mut [f64], v: f64x4) {
    let a = v.to_array();
    match out {
        [o0, o1, o2, o3] => (*o0, *o1, *o2, *o3) = (a[0], a[1], a[2], a[3]),
        [o0, o1, o2] => (*o0, *o1, *o2) = (a[0], a[1], a[2]),
        [o0, o1] => (*o0, *o1) = (a[0], a[1]),
        [o0] => *o0 = a[0],
        _ => unreachable!("a lane group holds one to four pairs"),
    }
}

/// Sum of the lanes in a fixed order.
#[inline(always)]
pub fn lane_sum(v: f64x4) -> f64 {
    let a = v.to_array();
    (a[0] + a[1]) + (a[2] + a[3])
}
