//! Command-line and JSON names of the library's option enums (solvers, stopping
//! criteria, filters, rescalings, repair methods). One table per enum gives it `ALL`,
//! `name()`, `Display`, `FromStr` and `Serialize`, so the names a front end accepts,
//! prints and serializes cannot drift apart, and an unknown name is a typed error of
//! the enum's module rather than a silent fallback.

/// `option_names!(Type, Error, |s| error_for_unknown_s, { Variant => "name", … })`
/// implements, for a field-less enum: `Type::ALL` (every value, in table order),
/// `Type::name`, `Display` (the name), `FromStr` (exactly the names; anything else is
/// the given error) and `Serialize` (the name as a string).
macro_rules! option_names {
    ($ty:ident, $err:ty, |$s:ident| $unknown:expr, { $($variant:ident => $name:literal),+ $(,)? }) => {
        impl $ty {
            /// Every value.
            pub const ALL: [$ty; [$($name),+].len()] = [$($ty::$variant),+];

            /// The name used on the command line and in JSON.
            pub fn name(self) -> &'static str {
                match self {
                    $($ty::$variant => $name,)+
                }
            }
        }

        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }

        impl std::str::FromStr for $ty {
            type Err = $err;
            fn from_str($s: &str) -> Result<Self, $err> {
                $ty::ALL
                    .into_iter()
                    .find(|v| v.name() == $s)
                    .ok_or_else(|| $unknown)
            }
        }

        impl serde::Serialize for $ty {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                serializer.serialize_str(self.name())
            }
        }
    };
}

pub(crate) use option_names;

#[cfg(test)]
mod tests {
    use crate::analysis::repair::{RepairError, RepairMethod};
    use crate::filter::{FilterError, FilterKind, Preserve, SolverKind};
    use crate::solve::{InputError, Stopping};
    use std::fmt::Debug;
    use std::str::FromStr;

    /// Every value parses back from its name, displays and serializes as its name,
    /// and the names are distinct; `unknown` is refused with the module's error.
    fn round_trip<T, E>(all: &[T], unknown: &str) -> E
    where
        T: FromStr<Err = E> + std::fmt::Display + serde::Serialize + PartialEq + Debug + Copy,
        E: Debug,
    {
        let mut names: Vec<String> = all.iter().map(T::to_string).collect();
        for (v, name) in all.iter().zip(&names) {
            assert_eq!(name.parse::<T>().unwrap(), *v);
            assert_eq!(serde_json::to_value(v).unwrap(), name.as_str());
        }
        names.sort();
        names.dedup();
        assert_eq!(names.len(), all.len());
        unknown.parse::<T>().unwrap_err()
    }

    #[test]
    fn names_round_trip_and_unknown_names_are_typed_errors() {
        assert!(matches!(
            round_trip(&Stopping::ALL, "strongest"),
            InputError::UnknownStopping(_)
        ));
        for e in [
            round_trip(&SolverKind::ALL, "gmres"),
            round_trip(&FilterKind::ALL, "gaussian"),
            round_trip(&Preserve::ALL, "area"),
        ] {
            assert!(matches!(e, FilterError::UnknownName { .. }), "{e}");
        }
        assert!(matches!(
            round_trip(&RepairMethod::ALL, "flip"),
            RepairError::UnknownMethod(_)
        ));
        assert_eq!(Preserve::BBox.name(), "bbox");
        assert_eq!(SolverKind::CgSym.to_string(), "cg-sym");
        assert_eq!(RepairMethod::SwapSplit.name(), "swap-split");
    }
}
