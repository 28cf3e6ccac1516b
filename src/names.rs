//! Values known by name: structures, traversals, heat-map measures. One
//! table per type gives each value its name (as the command line, the JSON
//! reports and the benchmarks spell it) and a one-line description; names
//! parse with [`std::str::FromStr`], no command-line crate needed.

/// An enum whose values have names and descriptions.
pub trait Named: Copy + PartialEq + 'static {
    /// What a value of this type is called in errors ("structure").
    const WHAT: &'static str;
    /// Every value with its name and description, in documentation order.
    const TABLE: &'static [(Self, &'static str, &'static str)];

    /// The value's name.
    fn name(self) -> &'static str {
        Self::TABLE
            .iter()
            .find(|(v, ..)| *v == self)
            .map(|&(_, n, _)| n)
            .expect("every value is in its table")
    }

    /// The value's one-line description.
    fn description(self) -> &'static str {
        Self::TABLE
            .iter()
            .find(|(v, ..)| *v == self)
            .map(|&(.., d)| d)
            .expect("every value is in its table")
    }

    /// The value named `s`; the error lists the names there are.
    fn from_name(s: &str) -> Result<Self, UnknownName> {
        Self::TABLE
            .iter()
            .find(|&&(_, n, _)| n == s)
            .map(|&(v, ..)| v)
            .ok_or_else(|| UnknownName {
                what: Self::WHAT,
                given: s.to_owned(),
                known: Self::TABLE.iter().map(|&(_, n, _)| n).collect(),
            })
    }
}

/// A name that is not in its type's table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownName {
    /// What was being named ("structure").
    pub what: &'static str,
    /// The name given.
    pub given: String,
    /// The names there are.
    pub known: Vec<&'static str>,
}

impl std::fmt::Display for UnknownName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "unknown {} '{}' (known: {})",
            self.what,
            self.given,
            self.known.join(", ")
        )
    }
}

impl std::error::Error for UnknownName {}

/// Implements [`std::str::FromStr`] and [`std::fmt::Display`] through
/// [`Named`].
#[macro_export]
macro_rules! named_from_str {
    ($t:ty) => {
        impl std::str::FromStr for $t {
            type Err = $crate::names::UnknownName;
            fn from_str(s: &str) -> ::std::result::Result<Self, Self::Err> {
                <$t as $crate::names::Named>::from_name(s)
            }
        }
        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str($crate::names::Named::name(*self))
            }
        }
    };
}
