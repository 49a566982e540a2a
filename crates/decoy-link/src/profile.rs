//! [`Profile`]: where the controller's aircraft kinematics come from, the State
//! frames or one of `decoy_schema`'s manoeuvres flown built in.
//!
//! On the wire a profile is an enum of postcard: its variant index
//! ([`Profile::code`]: 0 streamed, then 1 + the manoeuvre's position in
//! [`Manoeuvre::ALL`]), followed, for a manoeuvre with a rate
//! ([`Manoeuvre::has_rate`]), by the rate in mrad/s as a u16. That is the encoding
//! of the enum this type replaced (`Streamed`, `Steady`, `Acceleration`,
//! `PullUp { rate_milli_radps }`, `Turn { rate_milli_radps }`), byte for byte
//! (`tests/profile_bytes.rs`); a new manoeuvre is a new index at the end, with no
//! change here.

use core::fmt;

use decoy_schema::{Manoeuvre, STREAMED_PROFILE_CODE};
use serde::de::{self, EnumAccess, MapAccess, SeqAccess, Unexpected, VariantAccess, Visitor};
use serde::ser::SerializeStructVariant;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Where the aircraft kinematics come from.
///
/// Four bytes, aligned to two, as the enum it replaced: `Streamed` is the
/// manoeuvre's free value 0 ([`Manoeuvre`]'s discriminants start at 1), all zero
/// bits, so the decoy controller's unconfigured constant, which holds it, lies
/// in `.bss`, and the controller's fields keep their places (and the firmware
/// its code).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Profile {
    /// From the State frames (the normal mode).
    #[default]
    Streamed,
    /// A manoeuvre flown built in (docs/protocol.md, `Profile`; the flight is
    /// the manoeuvre's `decoy_schema::ManoeuvreInfo::builtin`): the State frames
    /// are the clock only.
    Builtin(BuiltinProfile),
}

/// A built-in profile: a manoeuvre and, for one with a rate, its flight-path
/// rotation rate. Its fields are private so that a manoeuvre without a rate
/// always has the rate 0 (it has none on the wire).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuiltinProfile {
    manoeuvre: Manoeuvre,
    rate_milli_radps: u16,
}

impl BuiltinProfile {
    /// `manoeuvre` at `rate_milli_radps` (positive: up for a pull-up, right for
    /// a turn), which a manoeuvre without a rate ignores (0).
    pub const fn new(manoeuvre: Manoeuvre, rate_milli_radps: u16) -> Self {
        BuiltinProfile {
            manoeuvre,
            rate_milli_radps: if manoeuvre.has_rate() {
                rate_milli_radps
            } else {
                0
            },
        }
    }

    /// The manoeuvre.
    pub const fn manoeuvre(self) -> Manoeuvre {
        self.manoeuvre
    }

    /// Flight-path rotation rate, mrad/s (0 for a manoeuvre without one).
    pub const fn rate_milli_radps(self) -> u16 {
        self.rate_milli_radps
    }
}

impl Profile {
    /// The built-in profile of `manoeuvre` (see [`BuiltinProfile::new`]).
    pub const fn builtin(manoeuvre: Manoeuvre, rate_milli_radps: u16) -> Self {
        Profile::Builtin(BuiltinProfile::new(manoeuvre, rate_milli_radps))
    }

    /// The manoeuvre flown built in, if any.
    pub const fn manoeuvre(self) -> Option<Manoeuvre> {
        match self {
            Profile::Streamed => None,
            Profile::Builtin(b) => Some(b.manoeuvre),
        }
    }

    /// Its number: the variant index on the wire, and the bridge's profile
    /// code ([`STREAMED_PROFILE_CODE`] or [`Manoeuvre::profile_code`]).
    pub const fn code(self) -> u16 {
        match self {
            Profile::Streamed => STREAMED_PROFILE_CODE,
            Profile::Builtin(b) => b.manoeuvre.profile_code(),
        }
    }
}

const _: () = assert!(
    core::mem::size_of::<Profile>() == 4 && core::mem::align_of::<Profile>() == 2,
    "Profile keeps the layout of the enum it replaced"
);

/// Serde's name of the type.
const NAME: &str = "Profile";
/// Serde's name of a built-in profile's rate.
const RATE: &str = "rate_milli_radps";
/// Serde's names of the variants, by code: `Streamed`, then each manoeuvre's
/// identifier.
const VARIANTS: [&str; 1 + Manoeuvre::ALL.len()] = {
    let mut names = ["Streamed"; 1 + Manoeuvre::ALL.len()];
    let mut i = 0;
    while i < Manoeuvre::ALL.len() {
        names[Manoeuvre::ALL[i].profile_code() as usize] = Manoeuvre::ALL[i].ident();
        i += 1;
    }
    names
};

impl Serialize for Profile {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let code = self.code();
        let name = VARIANTS[usize::from(code)];
        match self {
            Profile::Builtin(b) if b.manoeuvre.has_rate() => {
                let mut variant =
                    serializer.serialize_struct_variant(NAME, u32::from(code), name, 1)?;
                variant.serialize_field(RATE, &b.rate_milli_radps)?;
                variant.end()
            }
            _ => serializer.serialize_unit_variant(NAME, u32::from(code), name),
        }
    }
}

impl<'de> Deserialize<'de> for Profile {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_enum(NAME, &VARIANTS, ProfileVisitor)
    }
}

/// A variant: its index (postcard) or its name.
struct Code(u16);

impl<'de> Deserialize<'de> for Code {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_identifier(CodeVisitor)
    }
}

struct CodeVisitor;

impl Visitor<'_> for CodeVisitor {
    type Value = Code;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "a profile's variant index 0 <= i < {}", VARIANTS.len())
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Code, E> {
        match u16::try_from(v) {
            Ok(code) if usize::from(code) < VARIANTS.len() => Ok(Code(code)),
            _ => Err(E::invalid_value(Unexpected::Unsigned(v), &self)),
        }
    }

    fn visit_str<E: de::Error>(self, v: &str) -> Result<Code, E> {
        match VARIANTS.iter().position(|name| *name == v) {
            Some(code) => Ok(Code(code as u16)),
            None => Err(E::unknown_variant(v, &VARIANTS)),
        }
    }
}

struct ProfileVisitor;

impl<'de> Visitor<'de> for ProfileVisitor {
    type Value = Profile;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("enum Profile")
    }

    fn visit_enum<A: EnumAccess<'de>>(self, data: A) -> Result<Profile, A::Error> {
        let (Code(code), variant) = data.variant::<Code>()?;
        match Manoeuvre::from_profile_code(code) {
            Some(manoeuvre) if manoeuvre.has_rate() => variant
                .struct_variant(&[RATE], RateVisitor)
                .map(|rate| Profile::builtin(manoeuvre, rate)),
            Some(manoeuvre) => {
                variant.unit_variant()?;
                Ok(Profile::builtin(manoeuvre, 0))
            }
            None => {
                variant.unit_variant()?;
                Ok(Profile::Streamed)
            }
        }
    }
}

/// A built-in profile's fields: its rate.
struct RateVisitor;

impl<'de> Visitor<'de> for RateVisitor {
    type Value = u16;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a built-in profile's rate_milli_radps")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<u16, A::Error> {
        seq.next_element()?
            .ok_or_else(|| de::Error::invalid_length(0, &self))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<u16, A::Error> {
        let mut rate = None;
        while map.next_key::<RateField>()?.is_some() {
            if rate.is_some() {
                return Err(de::Error::duplicate_field(RATE));
            }
            rate = Some(map.next_value()?);
        }
        rate.ok_or_else(|| de::Error::missing_field(RATE))
    }
}

/// The one field of a built-in profile, by name or index.
struct RateField;

impl<'de> Deserialize<'de> for RateField {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct FieldVisitor;
        impl Visitor<'_> for FieldVisitor {
            type Value = RateField;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("the field rate_milli_radps")
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<RateField, E> {
                if v == 0 {
                    Ok(RateField)
                } else {
                    Err(E::invalid_value(Unexpected::Unsigned(v), &self))
                }
            }
            fn visit_str<E: de::Error>(self, v: &str) -> Result<RateField, E> {
                if v == RATE {
                    Ok(RateField)
                } else {
                    Err(E::unknown_field(v, &[RATE]))
                }
            }
        }
        deserializer.deserialize_identifier(FieldVisitor)
    }
}
