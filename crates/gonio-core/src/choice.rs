//! Named choices: an option's vocabulary (`--method least-squares`, `noise_model="readings"`) as
//! an enum with one name per variant (and optional aliases), read with `FromStr` and written
//! with `Display`, the same words on the command line and in Python. [`choices!`](crate::choices)
//! writes the impls; where the calling crate has a feature `clap` and it is on, it also writes
//! `clap::ValueEnum`, so that a flag's type is the enum itself.
//!
//! Errors: [`UnknownChoice`], which quotes the value (shortened) and lists the names.
//!
//! ```
//! #[derive(Debug, Clone, Copy, PartialEq, Eq)]
//! pub enum Fit {
//!     LeastSquares,
//!     Paper,
//! }
//! gonio_core::choices!(Fit { LeastSquares => "least-squares" | "ls", Paper => "paper" });
//!
//! assert_eq!("ls".parse::<Fit>(), Ok(Fit::LeastSquares));
//! assert_eq!(Fit::Paper.to_string(), "paper");
//! assert_eq!(Fit::NAMES, ["least-squares", "paper"]);
//! let e = "cubic".parse::<Fit>().unwrap_err();
//! assert_eq!(e.to_string(), "\"cubic\": expected least-squares or paper");
//! ```

/// A value that names none of the choices.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("\"{value}\": expected {expected}")]
pub struct UnknownChoice {
    /// The value given, shortened for messages ([`crate::text::short`]).
    pub value: String,
    /// The names, as `a, b or c`.
    pub expected: String,
}

impl UnknownChoice {
    /// The error for `value`, which is none of `names`.
    pub fn new(value: &str, names: &[&str]) -> UnknownChoice {
        let expected = match names {
            [] => String::new(),
            [one] => (*one).to_string(),
            [init @ .., last] => format!("{} or {last}", init.join(", ")),
        };
        UnknownChoice {
            value: crate::text::short(value),
            expected,
        }
    }
}

/// Implements a vocabulary for a field-less enum: `ALL` and `NAMES` (in the order given),
/// `name()`, `FromStr` (a name or one of its aliases, else [`UnknownChoice`]), `Display` (the
/// name) and, in a crate with the feature `clap` on, `clap::ValueEnum` (the names, the aliases
/// as clap aliases).
///
/// `choices!(Enum { Variant => "name" | "alias", … })`
#[macro_export]
macro_rules! choices {
    ($ty:ident { $($variant:ident => $name:literal $(| $alias:literal)*),+ $(,)? }) => {
        impl $ty {
            /// Every choice, in the order of `NAMES`.
            pub const ALL: &'static [$ty] = &[$($ty::$variant),+];
            /// The choices' names, as written on the command line and in Python.
            pub const NAMES: &'static [&'static str] = &[$($name),+];

            /// The name of this choice (on the command line, in Python and in files).
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }
        }

        impl ::core::str::FromStr for $ty {
            type Err = $crate::choice::UnknownChoice;

            fn from_str(s: &str) -> ::core::result::Result<Self, Self::Err> {
                match s {
                    $($name $(| $alias)* => Ok($ty::$variant),)+
                    _ => Err($crate::choice::UnknownChoice::new(s, Self::NAMES)),
                }
            }
        }

        impl ::core::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::core::fmt::Formatter<'_>) -> ::core::fmt::Result {
                f.write_str(self.name())
            }
        }

        #[cfg(feature = "clap")]
        impl ::clap::ValueEnum for $ty {
            fn value_variants<'a>() -> &'a [Self] {
                Self::ALL
            }

            fn to_possible_value(&self) -> ::core::option::Option<::clap::builder::PossibleValue> {
                Some(match self {
                    $($ty::$variant => ::clap::builder::PossibleValue::new($name)$(.alias($alias))*,)+
                })
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::UnknownChoice;

    #[test]
    fn the_expected_names_read_as_a_list() {
        assert_eq!(UnknownChoice::new("x", &["a"]).expected, "a");
        assert_eq!(UnknownChoice::new("x", &["a", "b"]).expected, "a or b");
        assert_eq!(
            UnknownChoice::new("x", &["full", "one", "seed"]).to_string(),
            "\"x\": expected full, one or seed"
        );
        // A long or hostile value is shortened and its control characters escaped.
        let e = UnknownChoice::new(&"\u{7}".repeat(1000), &["a"]).to_string();
        assert!(e.len() < 400 && !e.contains('\u{7}'), "{e}");
    }
}
