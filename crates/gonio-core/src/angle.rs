//! Angles and lengths as types with explicit units.
//!
//! Metrology mixes degrees (table positions), arcseconds (errors) and radians (trigonometry);
//! a bare `f64` invites a factor-3600 mistake. These newtypes convert only explicitly, through
//! `From`, and support the arithmetic that keeps the unit (sum, difference, scaling).
//!
//! ```
//! use gonio_core::{Arcsec, Degrees, Radians};
//! let step = Degrees(15.0);
//! assert_eq!(Arcsec::from(step).0, 54_000.0);
//! assert!((Radians::from(Degrees(180.0)).0 - std::f64::consts::PI).abs() < 1e-15);
//! ```

use serde::{Deserialize, Serialize};
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub, SubAssign};

/// Arcseconds in one degree.
pub const ARCSEC_PER_DEGREE: f64 = 3600.0;
/// Arcseconds in one radian (648 000 / π).
pub const ARCSEC_PER_RADIAN: f64 = 648_000.0 / std::f64::consts::PI;

macro_rules! unit {
    ($(#[$m:meta])* $name:ident, $sym:literal) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub f64);

        impl $name {
            /// The bare number in this unit.
            #[inline]
            pub fn value(self) -> f64 {
                self.0
            }
            /// Absolute value.
            #[inline]
            pub fn abs(self) -> Self {
                Self(self.0.abs())
            }
        }
        impl Add for $name {
            type Output = Self;
            #[inline]
            fn add(self, o: Self) -> Self {
                Self(self.0 + o.0)
            }
        }
        impl Sub for $name {
            type Output = Self;
            #[inline]
            fn sub(self, o: Self) -> Self {
                Self(self.0 - o.0)
            }
        }
        impl AddAssign for $name {
            #[inline]
            fn add_assign(&mut self, o: Self) {
                self.0 += o.0;
            }
        }
        impl SubAssign for $name {
            #[inline]
            fn sub_assign(&mut self, o: Self) {
                self.0 -= o.0;
            }
        }
        impl Neg for $name {
            type Output = Self;
            #[inline]
            fn neg(self) -> Self {
                Self(-self.0)
            }
        }
        impl Mul<f64> for $name {
            type Output = Self;
            #[inline]
            fn mul(self, k: f64) -> Self {
                Self(self.0 * k)
            }
        }
        impl Div<f64> for $name {
            type Output = Self;
            #[inline]
            fn div(self, k: f64) -> Self {
                Self(self.0 / k)
            }
        }
        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                if let Some(p) = f.precision() {
                    write!(f, "{:.*}{}", p, self.0, $sym)
                } else {
                    write!(f, "{}{}", self.0, $sym)
                }
            }
        }
    };
}

unit!(
    /// An angle in arcseconds (″), the unit of encoder and polygon errors.
    Arcsec,
    "″"
);
unit!(
    /// An angle in degrees (°), the unit of table positions.
    Degrees,
    "°"
);
unit!(
    /// An angle in radians, the unit of trigonometry.
    Radians,
    " rad"
);
unit!(
    /// A length in micrometres (µm), the unit of eccentricity.
    Micrometres,
    " µm"
);
unit!(
    /// A length in camera pixels (px).
    Pixels,
    " px"
);

impl From<Degrees> for Arcsec {
    fn from(d: Degrees) -> Self {
        Arcsec(d.0 * ARCSEC_PER_DEGREE)
    }
}
impl From<Arcsec> for Degrees {
    fn from(a: Arcsec) -> Self {
        Degrees(a.0 / ARCSEC_PER_DEGREE)
    }
}
impl From<Degrees> for Radians {
    fn from(d: Degrees) -> Self {
        Radians(d.0.to_radians())
    }
}
impl From<Radians> for Degrees {
    fn from(r: Radians) -> Self {
        Degrees(r.0.to_degrees())
    }
}
impl From<Arcsec> for Radians {
    fn from(a: Arcsec) -> Self {
        Radians(a.0 / ARCSEC_PER_RADIAN)
    }
}
impl From<Radians> for Arcsec {
    fn from(r: Radians) -> Self {
        Arcsec(r.0 * ARCSEC_PER_RADIAN)
    }
}

impl Degrees {
    /// The same direction reduced to `[0, 360)`.
    ///
    /// ```
    /// use gonio_core::Degrees;
    /// assert_eq!(Degrees(370.0).normalized().0, 10.0);
    /// assert_eq!(Degrees(-15.0).normalized().0, 345.0);
    /// ```
    pub fn normalized(self) -> Degrees {
        let r = self.0.rem_euclid(360.0);
        // rem_euclid can return 360.0 for tiny negative inputs.
        Degrees(if r >= 360.0 { 0.0 } else { r })
    }
}

impl Radians {
    /// The same direction reduced to `(-π, π]`.
    pub fn wrapped(self) -> Radians {
        use std::f64::consts::{PI, TAU};
        let mut r = self.0.rem_euclid(TAU);
        if r > PI {
            r -= TAU;
        }
        Radians(r)
    }
}

impl Micrometres {
    /// Converts to pixels for a given scale in µm per pixel.
    pub fn to_pixels(self, um_per_px: f64) -> Pixels {
        Pixels(self.0 / um_per_px)
    }
}

impl Pixels {
    /// Converts to micrometres for a given scale in µm per pixel.
    pub fn to_micrometres(self, um_per_px: f64) -> Micrometres {
        Micrometres(self.0 * um_per_px)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        let d = Degrees(123.456);
        assert!((Degrees::from(Arcsec::from(d)).0 - d.0).abs() < 1e-12);
        assert!((Degrees::from(Radians::from(d)).0 - d.0).abs() < 1e-12);
        let a = Arcsec(1.0);
        assert!((Arcsec::from(Radians::from(a)).0 - 1.0).abs() < 1e-12);
        assert!((ARCSEC_PER_RADIAN - 206_264.806_247_096_36).abs() < 1e-6);
    }

    #[test]
    fn wrapping() {
        assert_eq!(Degrees(720.0).normalized().0, 0.0);
        assert!(Degrees(-1e-18).normalized().0 < 360.0);
        let w = Radians(3.0 * std::f64::consts::PI).wrapped().0;
        assert!((w - std::f64::consts::PI).abs() < 1e-12);
    }

    #[test]
    fn display_keeps_unit() {
        assert_eq!(format!("{:.2}", Arcsec(0.153)), "0.15″");
        assert_eq!(format!("{:.1}", Micrometres(3.84)), "3.8 µm");
    }
}
