//! Closed intervals of `f64` with outward rounding, for the validated enclosures of
//! [`crate::reach_box`].
//!
//! Every arithmetic result is rounded outward by one unit in the last place (`next_down` / `next_up`),
//! which encloses the exact result of an IEEE round-to-nearest operation (error at most half a unit).
//! `sin` and `cos` come from the platform's libm, accurate to about one unit in the last place on these
//! arguments; their enclosures are widened by [`TRIG_PAD`] (about nine units at 1), then clamped to
//! `[-1, 1]`.
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// The absolute widening of every `sin` and `cos` enclosure.
pub const TRIG_PAD: f64 = 1e-15;

/// The closed interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Iv {
    pub lo: f64,
    pub hi: f64,
}

impl Iv {
    /// `[lo, hi]` as given (no rounding).
    pub const fn new(lo: f64, hi: f64) -> Self {
        Self { lo, hi }
    }

    /// The point `x`.
    pub const fn point(x: f64) -> Self {
        Self { lo: x, hi: x }
    }

    /// `[lo, hi]` widened by one unit in the last place each way.
    #[inline]
    pub fn out(lo: f64, hi: f64) -> Self {
        Self {
            lo: lo.next_down(),
            hi: hi.next_up(),
        }
    }

    /// `[lo - pad, hi + pad]`, rounded outward.
    #[inline]
    pub fn pad(self, pad: f64) -> Self {
        Self::out(self.lo - pad, self.hi + pad)
    }

    /// Whether the interval holds no point.
    #[inline]
    pub fn is_empty(self) -> bool {
        self.lo > self.hi || self.lo.is_nan() || self.hi.is_nan()
    }

    /// The width, `hi - lo`.
    pub fn width(self) -> f64 {
        self.hi - self.lo
    }

    /// Whether `x` lies in the interval.
    pub fn contains(self, x: f64) -> bool {
        self.lo <= x && x <= self.hi
    }

    /// The intersection (empty when they do not meet; exact).
    #[inline]
    pub fn meet(self, o: Self) -> Self {
        Self {
            lo: self.lo.max(o.lo),
            hi: self.hi.min(o.hi),
        }
    }

    /// The smallest interval holding both (exact).
    #[inline]
    pub fn hull(self, o: Self) -> Self {
        Self {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// The smallest absolute value in the interval.
    pub fn mag_lo(self) -> f64 {
        if self.lo > 0.0 {
            self.lo
        } else if self.hi < 0.0 {
            -self.hi
        } else {
            0.0
        }
    }

    /// `1 / self`; `None` when the interval holds 0.
    #[inline]
    pub fn recip(self) -> Option<Self> {
        if self.lo > 0.0 || self.hi < 0.0 {
            Some(Self::out(1.0 / self.hi, 1.0 / self.lo))
        } else {
            None
        }
    }

    /// `self * c` for a number `c`.
    #[inline]
    pub fn scale(self, c: f64) -> Self {
        let (a, b) = (self.lo * c, self.hi * c);
        Self::out(a.min(b), a.max(b))
    }

    /// The enclosure of `cos` over the interval.
    pub fn cos(self) -> Self {
        if self.width() >= TAU {
            return Self::new(-1.0, 1.0);
        }
        let (a, b) = (self.lo.cos(), self.hi.cos());
        let (mut lo, mut hi) = (a.min(b), a.max(b));
        // maxima at 2 k pi, minima at (2 k + 1) pi
        if (self.lo / TAU).ceil() <= (self.hi / TAU).floor() {
            hi = 1.0;
        }
        if ((self.lo - PI) / TAU).ceil() <= ((self.hi - PI) / TAU).floor() {
            lo = -1.0;
        }
        Self::new((lo - TRIG_PAD).max(-1.0), (hi + TRIG_PAD).min(1.0))
    }

    /// The enclosure of `sin` over the interval.
    pub fn sin(self) -> Self {
        if self.width() >= TAU {
            return Self::new(-1.0, 1.0);
        }
        let (a, b) = (self.lo.sin(), self.hi.sin());
        let (mut lo, mut hi) = (a.min(b), a.max(b));
        // maxima at pi/2 + 2 k pi, minima at -pi/2 + 2 k pi
        if ((self.lo - FRAC_PI_2) / TAU).ceil() <= ((self.hi - FRAC_PI_2) / TAU).floor() {
            hi = 1.0;
        }
        if ((self.lo + FRAC_PI_2) / TAU).ceil() <= ((self.hi + FRAC_PI_2) / TAU).floor() {
            lo = -1.0;
        }
        Self::new((lo - TRIG_PAD).max(-1.0), (hi + TRIG_PAD).min(1.0))
    }
}

impl std::ops::Add for Iv {
    type Output = Iv;
    #[inline]
    fn add(self, o: Iv) -> Iv {
        Iv::out(self.lo + o.lo, self.hi + o.hi)
    }
}

impl std::ops::Sub for Iv {
    type Output = Iv;
    #[inline]
    fn sub(self, o: Iv) -> Iv {
        Iv::out(self.lo - o.hi, self.hi - o.lo)
    }
}

impl std::ops::Neg for Iv {
    type Output = Iv;
    #[inline]
    fn neg(self) -> Iv {
        Iv::new(-self.hi, -self.lo)
    }
}

impl std::ops::Mul for Iv {
    type Output = Iv;
    #[inline]
    fn mul(self, o: Iv) -> Iv {
        let p = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        let lo = p.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = p.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Iv::out(lo, hi)
    }
}
