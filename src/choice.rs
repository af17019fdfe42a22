//! Settings chosen by name (`--filter blackman-harris`, chart labels, EXR
//! headers): each such enum has one table of names, declared with
//! [`choice!`], from which its `Display` and `FromStr` follow. The command
//! line offers the same table, so the library's types carry no parser.

use thiserror::Error;

/// An enum whose every variant has one name.
pub trait Choice: Copy + PartialEq + 'static {
    /// Every variant and its name, in the order help lists them.
    const NAMES: &'static [(Self, &'static str)];

    /// This variant's name.
    fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(value, _)| *value == self)
            .map(|(_, name)| *name)
            .expect("every variant is in its name table")
    }

    /// The variant called `name`, or an error listing the names there are.
    fn from_name(name: &str) -> Result<Self, UnknownChoice> {
        Self::NAMES
            .iter()
            .find(|(_, n)| *n == name)
            .map(|(value, _)| *value)
            .ok_or_else(|| UnknownChoice {
                given: name.to_string(),
                names: Self::NAMES.iter().map(|(_, n)| *n).collect(),
            })
    }
}

/// A name that is not in a [`Choice`]'s table.
#[derive(Debug, Error)]
#[error("unknown value '{given}' (expected one of: {})", names.join(", "))]
pub struct UnknownChoice {
    /// What was given.
    pub given: String,
    /// The names there are.
    pub names: Vec<&'static str>,
}

/// Implements [`Choice`], `Display` and `FromStr` for a fieldless enum from
/// one table: `choice!(FilterKind { Box => "box", BlackmanHarris =>
/// "blackman-harris" });`.
macro_rules! choice {
    ($ty:ident { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $crate::choice::Choice for $ty {
            const NAMES: &'static [(Self, &'static str)] = &[$(($ty::$variant, $name)),+];
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str($crate::choice::Choice::name(*self))
            }
        }

        impl std::str::FromStr for $ty {
            type Err = $crate::choice::UnknownChoice;

            fn from_str(name: &str) -> Result<Self, Self::Err> {
                <Self as $crate::choice::Choice>::from_name(name)
            }
        }
    };
}
pub(crate) use choice;
