//! The decoy management's requirements, listed once.
//!
//! The paper opens with what decoy management must guarantee: the decoy's
//! posture stays stable, the decoy and cable never collide with the aircraft,
//! the cable tension stays within its limits, the cable stays out of the hot
//! exhaust jet. The controller watches each with a monitor and predicts it with
//! its look-ahead (docs/management.md); every layer that holds or shows one value
//! per requirement (the monitors' state and thresholds, the look-ahead's
//! prediction, the configuration, the link's and the bridge's reports, the
//! output files' columns, the plots, the summaries) takes the list from here:
//!
//! - [`Requirement`], one variant per requirement, with its name, the unit of its
//!   margin (on the wire and in the controller), the unit of its margin in the
//!   output files, a title and the definition of its margin;
//! - [`PerRequirement`], one value per requirement in named fields, indexed by
//!   [`Requirement`];
//! - [`for_each_requirement!`](crate::for_each_requirement), the list itself as
//!   a declarative macro that hands every entry to a callback macro: what
//!   cannot be generic (the bridge's `#[repr(C)]` wire struct with one field per
//!   requirement, constant column names) is generated from it.
//!
//! A new requirement is one entry of the list (and its monitor in
//! `decoy_controller::monitor`, its `[management.<name>]` section in
//! `decoy-config`): the container gains its field, the wire types, columns and
//! plots theirs. It changes the wire formats, so the link's and the bridge's
//! protocol versions.
//!
//! The order of the list is the wire order (postcard encodes a
//! [`PerRequirement`] as its fields one after the other, as it does an array)
//! and each requirement's index is its bit in the advisory bits.

use core::ops::{Index, IndexMut};

use serde::{Deserialize, Serialize};

/// The requirement list: calls `$callback! { $($prefix)* entries }` with one entry
/// per requirement, in wire order,
/// `(Variant, field, "margin unit", "file unit", "title", "margin definition")`:
///
/// - `Variant`: the [`Requirement`] variant;
/// - `field`: its name, the field of [`PerRequirement`] and of the wire types,
///   the prefix of its columns and its `[management.<field>]` section;
/// - the unit of its margin on the wire and in the controller (SI);
/// - the unit of its margin in the output files (degrees where the wire has
///   radians; [`Requirement::to_file_unit`] converts), which ends the margin's
///   column name (`posture_margin_deg`): letters, digits and `_` only;
/// - a title (one line);
/// - the definition of its margin (negative: violated), for documents.
///
/// Any tokens given after the callback's name are passed first, followed by a
/// `;` (for a callback that needs more than the list).
///
/// ```
/// macro_rules! names {
///     ($(($variant:ident, $field:ident, $unit:literal, $file_unit:literal,
///         $title:literal, $margin:literal)),* $(,)?) => {
///         [$(stringify!($field)),*]
///     };
/// }
/// assert_eq!(
///     decoy_schema::for_each_requirement!(names),
///     ["posture", "collision", "tension", "exhaust"]
/// );
/// ```
#[macro_export]
macro_rules! for_each_requirement {
    ($callback:ident $(, $($prefix:tt)*)?) => {
        $callback! {
            $($($prefix)* ;)?
            (
                Posture,
                posture,
                "rad",
                "deg",
                "Decoy posture stable",
                "the smaller of (the oscillation limit - the decoy's pitch/yaw oscillation amplitude over the sliding window, or the amplitude its growth projects half a window ahead) and (the aero table's usable angle of attack - the decoy's total angle of attack)"
            ),
            (
                Collision,
                collision,
                "m",
                "m",
                "Decoy and cable clear of the aircraft",
                "the smallest clearance of the decoy CG and of the cable (joints and segment midpoints beyond `collision.cable_exclusion_m` along it from the connection point) to the aircraft's collision capsule, minus `collision.min_clearance_m`"
            ),
            (
                Tension,
                tension,
                "N",
                "N",
                "Cable tension within the allowable and above slack",
                "the side at the higher level of (`cable.allowable_tension` - the highest joint tension) and (the lowest joint tension - `tension.slack_n`), each against its own thresholds"
            ),
            (
                Exhaust,
                exhaust,
                "m",
                "m",
                "Cable out of the hot exhaust jet",
                "the cable's clearance to the exhaust plume (every joint and segment midpoint) minus `exhaust.min_clearance_m`"
            ),
        }
    };
}

/// Degrees per radian, as `f64::to_degrees` multiplies (the same bits).
const DEGREES_PER_RADIAN: f64 = 180.0 / core::f64::consts::PI;

macro_rules! define_requirements {
    ($(($variant:ident, $field:ident, $unit:literal, $file_unit:literal,
        $title:literal, $margin:literal)),* $(,)?) => {
        /// One of the decoy management's requirements (the list:
        /// [`for_each_requirement!`](crate::for_each_requirement)), in wire order.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
        #[serde(rename_all = "snake_case")]
        pub enum Requirement {
            $(
                #[doc = concat!($title, ": margin in ", $unit, ", ", $margin, ".")]
                $variant,
            )*
        }

        impl Requirement {
            /// Every requirement, in wire order.
            pub const ALL: [Requirement; REQUIREMENT_COUNT] = [$(Requirement::$variant),*];

            /// The requirement's name (`posture`): the field of
            /// [`PerRequirement`] and of the wire types, the prefix of its
            /// columns, its `[management.<name>]` section.
            pub const fn name(self) -> &'static str {
                match self {
                    $(Requirement::$variant => stringify!($field),)*
                }
            }

            /// The unit of its margin on the wire and in the controller (SI:
            /// `rad`, `m`, `N`).
            pub const fn unit(self) -> &'static str {
                match self {
                    $(Requirement::$variant => $unit,)*
                }
            }

            /// The unit of its margin in the output files (`deg` for an angle).
            pub const fn file_unit(self) -> &'static str {
                match self {
                    $(Requirement::$variant => $file_unit,)*
                }
            }

            /// A one-line title (`Decoy posture stable`).
            pub const fn title(self) -> &'static str {
                match self {
                    $(Requirement::$variant => $title,)*
                }
            }

            /// What its margin is (negative: the requirement is violated).
            pub const fn margin(self) -> &'static str {
                match self {
                    $(Requirement::$variant => $margin,)*
                }
            }

            /// The requirement named `name` ([`Requirement::name`]).
            pub fn from_name(name: &str) -> Option<Requirement> {
                Requirement::ALL.into_iter().find(|r| r.name() == name)
            }
        }

        /// One value per requirement, in named fields (wire order).
        ///
        /// Serialised as a struct of those fields: in postcard that is the
        /// values one after the other, the bytes of an array of them; in JSON
        /// an object keyed by the requirements' names. `#[repr(C)]`: laid out
        /// as an array of the values.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
        #[repr(C)]
        pub struct PerRequirement<T> {
            $(
                #[doc = concat!($title, " (margin in ", $unit, ").")]
                pub $field: T,
            )*
        }

        impl<T> PerRequirement<T> {
            /// The value of every requirement from `f`, called in wire order.
            #[inline(always)]
            pub fn from_fn(mut f: impl FnMut(Requirement) -> T) -> Self {
                PerRequirement {
                    $($field: f(Requirement::$variant),)*
                }
            }

            /// The values in wire order.
            #[inline(always)]
            pub fn into_array(self) -> [T; REQUIREMENT_COUNT] {
                [$(self.$field),*]
            }

            /// From the values in wire order.
            #[inline(always)]
            pub fn from_array(values: [T; REQUIREMENT_COUNT]) -> Self {
                let [$($field),*] = values;
                PerRequirement { $($field),* }
            }

            /// References to the values.
            #[inline(always)]
            pub fn as_ref(&self) -> PerRequirement<&T> {
                PerRequirement { $($field: &self.$field,)* }
            }

            /// Mutable references to the values.
            #[inline(always)]
            pub fn as_mut(&mut self) -> PerRequirement<&mut T> {
                PerRequirement { $($field: &mut self.$field,)* }
            }

            /// Each value through `f`, in wire order.
            #[inline(always)]
            pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> PerRequirement<U> {
                PerRequirement { $($field: f(self.$field),)* }
            }

            /// Each requirement with its value through `f`, in wire order.
            #[inline(always)]
            pub fn map_with<U>(self, mut f: impl FnMut(Requirement, T) -> U) -> PerRequirement<U> {
                PerRequirement { $($field: f(Requirement::$variant, self.$field),)* }
            }

            /// The values of `self` and `other` paired, requirement by requirement.
            #[inline(always)]
            pub fn zip<U>(self, other: PerRequirement<U>) -> PerRequirement<(T, U)> {
                PerRequirement { $($field: (self.$field, other.$field),)* }
            }

            /// Each requirement with a reference to its value, in wire order.
            #[inline(always)]
            pub fn iter(&self) -> core::array::IntoIter<(Requirement, &T), REQUIREMENT_COUNT> {
                [$((Requirement::$variant, &self.$field)),*].into_iter()
            }

            /// Each requirement with a mutable reference to its value, in wire order.
            #[inline(always)]
            pub fn iter_mut(&mut self) -> core::array::IntoIter<(Requirement, &mut T), REQUIREMENT_COUNT> {
                [$((Requirement::$variant, &mut self.$field)),*].into_iter()
            }
        }

        impl<T: Copy> PerRequirement<T> {
            /// `value` for every requirement (a `const fn`, for constants).
            pub const fn splat(value: T) -> Self {
                PerRequirement { $($field: value,)* }
            }
        }

        impl<T> Index<Requirement> for PerRequirement<T> {
            type Output = T;

            #[inline(always)]
            fn index(&self, requirement: Requirement) -> &T {
                match requirement {
                    $(Requirement::$variant => &self.$field,)*
                }
            }
        }

        impl<T> IndexMut<Requirement> for PerRequirement<T> {
            #[inline(always)]
            fn index_mut(&mut self, requirement: Requirement) -> &mut T {
                match requirement {
                    $(Requirement::$variant => &mut self.$field,)*
                }
            }
        }
    };
}

/// How many requirements there are.
pub const REQUIREMENT_COUNT: usize = {
    macro_rules! count {
        ($(($variant:ident, $($rest:tt)*)),* $(,)?) => {
            [$(stringify!($variant)),*].len()
        };
    }
    for_each_requirement!(count)
};

for_each_requirement!(define_requirements);

impl Requirement {
    /// The requirement's position in wire order (0 posture, ...).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Its bit in the advisory bits (1 posture, 2 collision, 4 tension, 8
    /// exhaust): `1 << index`.
    pub const fn bit(self) -> u8 {
        1 << self.index()
    }

    /// `margin` (in [`Requirement::unit`]) in [`Requirement::file_unit`]: radians
    /// to degrees (as `f64::to_degrees`, the same bits), else as it is.
    pub fn to_file_unit(self, margin: f64) -> f64 {
        if str_eq(self.unit(), "rad") && str_eq(self.file_unit(), "deg") {
            margin * DEGREES_PER_RADIAN
        } else {
            margin
        }
    }
}

impl Requirement {
    /// The Markdown table of the requirements (`| bit | requirement | unit |
    /// margin |`, a row per requirement in wire order, each line ended by a
    /// newline), as docs/management.md shows it.
    pub fn markdown_table() -> RequirementTable {
        RequirementTable
    }
}

/// The requirements' table in Markdown ([`Requirement::markdown_table`]).
#[derive(Clone, Copy, Debug)]
pub struct RequirementTable;

impl core::fmt::Display for RequirementTable {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("| bit | requirement | margin unit (files) | margin (negative: violated) |\n|---|---|---|---|\n")?;
        for r in Requirement::ALL {
            write!(
                f,
                "| {} | `{}`: {} | {}",
                r.bit(),
                r.name(),
                r.title(),
                r.unit()
            )?;
            if !str_eq(r.unit(), r.file_unit()) {
                write!(f, " ({})", r.file_unit())?;
            }
            writeln!(f, " | {} |", r.margin())?;
        }
        Ok(())
    }
}

/// `a == b` for string constants (a `const fn`).
const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

// Every unit pair is one `to_file_unit` converts: the same unit, or rad to deg.
const _: () = {
    let mut i = 0;
    while i < REQUIREMENT_COUNT {
        let r = Requirement::ALL[i];
        assert!(
            str_eq(r.unit(), r.file_unit())
                || (str_eq(r.unit(), "rad") && str_eq(r.file_unit(), "deg")),
            "a requirement's file unit must be its unit, or deg for rad"
        );
        assert!(r.index() == i, "Requirement::ALL is in declaration order");
        // The file unit ends the margin's column name (`posture_margin_deg`).
        let unit = r.file_unit().as_bytes();
        let mut k = 0;
        while k < unit.len() {
            assert!(
                unit[k].is_ascii_alphanumeric() || unit[k] == b'_',
                "a requirement's file unit ends a column name: letters, digits and `_` only (`radps`, not `rad/s`)"
            );
            k += 1;
        }
        i += 1;
    }
    // The advisory bits are a u8.
    assert!(
        REQUIREMENT_COUNT <= 8,
        "at most 8 requirements: the advisory bits are a u8"
    );
};

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    #[test]
    fn the_list_is_in_wire_order_with_names_units_and_bits() {
        let names: Vec<_> = Requirement::ALL.iter().map(|r| r.name()).collect();
        assert_eq!(names, ["posture", "collision", "tension", "exhaust"]);
        let units: Vec<_> = Requirement::ALL.iter().map(|r| r.unit()).collect();
        assert_eq!(units, ["rad", "m", "N", "m"]);
        let file_units: Vec<_> = Requirement::ALL.iter().map(|r| r.file_unit()).collect();
        assert_eq!(file_units, ["deg", "m", "N", "m"]);
        let bits: Vec<_> = Requirement::ALL.iter().map(|r| r.bit()).collect();
        assert_eq!(bits, [1, 2, 4, 8]);
        for r in Requirement::ALL {
            assert_eq!(Requirement::from_name(r.name()), Some(r));
        }
        assert_eq!(Requirement::from_name("exhausts"), None);
    }

    #[test]
    fn file_units_convert_as_to_degrees_does() {
        for v in [0.0, -0.0, 1e-9, 0.1745, -3.5, 1e30, f64::MIN_POSITIVE] {
            assert_eq!(
                Requirement::Posture.to_file_unit(v).to_bits(),
                v.to_degrees().to_bits()
            );
            assert_eq!(Requirement::Tension.to_file_unit(v).to_bits(), v.to_bits());
        }
    }

    #[test]
    fn the_container_indexes_maps_and_iterates_in_wire_order() {
        let indices: Vec<usize> = Requirement::ALL.iter().map(|r| r.index()).collect();
        assert_eq!(indices, (0..REQUIREMENT_COUNT).collect::<Vec<_>>());
        let p = PerRequirement::from_fn(|r| r.index() * 10);
        let tens: Vec<usize> = indices.iter().map(|k| k * 10).collect();
        assert_eq!(p.into_array().to_vec(), tens);
        assert_eq!(PerRequirement::from_array(p.into_array()), p);
        assert_eq!(p[Requirement::Tension], 20);
        assert_eq!(p.tension, 20);
        let mut q = p.map(|v| v + 1);
        q[Requirement::Exhaust] = 0;
        assert_eq!((q.posture, q.tension, q.exhaust), (1, 21, 0));
        let pairs: Vec<_> = p.iter().map(|(r, v)| (r, *v)).collect();
        let expected: Vec<_> = Requirement::ALL
            .iter()
            .map(|r| (*r, r.index() * 10))
            .collect();
        assert_eq!(pairs, expected);
        for (r, v) in q.iter_mut() {
            *v = r.bit().into();
        }
        for r in Requirement::ALL {
            assert_eq!(q[r], 1 << r.index());
            assert_eq!(
                p.zip(q).map(|(a, b)| a + b)[r],
                10 * r.index() + (1 << r.index())
            );
            assert_eq!(p.map_with(|r, v| v + r.index())[r], 11 * r.index());
            assert_eq!(PerRequirement::splat(7)[r], 7);
        }
        assert_eq!(*p.as_ref().tension, 20);
        let mut m = p;
        *m.as_mut().posture = 5;
        assert_eq!(m.posture, 5);
    }

    /// The container has the layout of an array of its values.
    #[test]
    fn the_container_is_laid_out_as_an_array() {
        assert_eq!(
            core::mem::size_of::<PerRequirement<u64>>(),
            core::mem::size_of::<[u64; REQUIREMENT_COUNT]>()
        );
        assert_eq!(core::mem::offset_of!(PerRequirement<u32>, exhaust), 12);
    }
}
