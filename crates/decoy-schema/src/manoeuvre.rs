//! The manoeuvres: the aircraft motions the product prescribes (the paper's
//! flight profiles), each named and described once.
//!
//! [`Manoeuvre`] is the one list of them, and every layer reads it: solver-core's
//! `profiles` fly each one (`ManoeuvrePath::new`), the controller flies each as a
//! built-in profile ([`ManoeuvreInfo::builtin`]) selected over the decoy link by
//! its [`Manoeuvre::profile_code`], the scenario files and the command line name
//! it ([`Manoeuvre::name`]) and give its [`Parameter`]s, and the bridge's codes
//! and the Python client spell it as an identifier ([`Manoeuvre::ident`]).
//!
//! What is not a manoeuvre belongs to the layer that has it: a recorded flight
//! is a kind of scenario (decoy-sim's `ScenarioKind::Recorded`), and streamed
//! kinematics are the decoy link's normal profile (`decoy_link::Profile::Streamed`,
//! code [`STREAMED_PROFILE_CODE`]).
//!
//! A new manoeuvre is a variant here, appended (its position is its code on the
//! link and the bridge), with its row in [`Manoeuvre::info`], and its flight path
//! in solver-core's `profiles`.

use serde::{Deserialize, Serialize};

/// A prescribed manoeuvre of the aircraft.
///
/// Serde spells it as in the scenario files (`pull-up`). The declaration order
/// is the order of [`Manoeuvre::ALL`] and gives each its
/// [`Manoeuvre::profile_code`], its discriminant: new manoeuvres are appended,
/// never inserted. The discriminants start at 1, leaving 0 free: a type that
/// holds a manoeuvre or nothing keeps its nothing there, all zero bits
/// (`decoy_link::Profile::Streamed`, in the decoy controller's unconfigured
/// constant, which must lie in `.bss`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
#[repr(u8)]
pub enum Manoeuvre {
    /// Steady level flight.
    Steady = 1,
    /// A level acceleration (or deceleration) between two speeds.
    Acceleration,
    /// Level flight, then the flight path rotating up at a constant rate, then
    /// the climb held.
    PullUp,
    /// Level flight, then a level coordinated turn at a constant rate.
    Turn,
}

/// A manoeuvre's parameter, as a scenario file gives it.
///
/// Every manoeuvre starts in level flight at an altitude and a Mach number; the
/// others are the manoeuvre's own ([`ManoeuvreInfo::parameters`]). The order of
/// [`Parameter::ALL`] is the order in which a scenario's keys are checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Parameter {
    /// Initial altitude, m.
    Altitude,
    /// Initial Mach number.
    Mach,
    /// Mach number after the acceleration.
    FinalMach,
    /// When the acceleration starts, s.
    AccelerationStart,
    /// Along-track acceleration, m/s^2 (its sign follows the Mach numbers).
    Acceleration,
    /// Flight-path rotation rate, rad/s (pull-up: positive up; turn: positive
    /// right).
    Rate,
    /// When the rotation starts, s.
    Start,
    /// How long the flight path rotates, s.
    Duration,
}

impl Parameter {
    /// Every parameter, in the order a scenario's keys are checked.
    pub const ALL: [Parameter; 8] = [
        Parameter::Altitude,
        Parameter::Mach,
        Parameter::FinalMach,
        Parameter::AccelerationStart,
        Parameter::Acceleration,
        Parameter::Rate,
        Parameter::Start,
        Parameter::Duration,
    ];

    /// Its key in a scenario file (`rate_radps`, ...).
    pub const fn key(self) -> &'static str {
        match self {
            Parameter::Altitude => "altitude_m",
            Parameter::Mach => "mach",
            Parameter::FinalMach => "final_mach",
            Parameter::AccelerationStart => "accel_start_s",
            Parameter::Acceleration => "acceleration_mps2",
            Parameter::Rate => "rate_radps",
            Parameter::Start => "start_s",
            Parameter::Duration => "duration_s",
        }
    }
}

/// Whether a manoeuvre needs one of its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Need {
    /// A scenario must give it.
    Required,
    /// A scenario may give it; 0 when it does not.
    Optional,
}

/// The flight the decoy controller flies when the link selects a manoeuvre as
/// its built-in profile (docs/protocol.md, `Profile`), at
/// [`BUILTIN_ALTITUDE_M`], the rate aside, which the command carries. The
/// shipped scenario of the same name flies the same path (decoy-sim tests it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuiltinFlight {
    /// Initial Mach number.
    pub mach: f64,
    /// Mach number after the acceleration (the initial one if none).
    pub final_mach: f64,
    /// When the manoeuvre starts (the acceleration or the rotation), s.
    pub start_s: f64,
    /// Along-track acceleration, m/s^2 (0 if none).
    pub acceleration_mps2: f64,
    /// How long the flight path rotates, s (0 if it does not stop).
    pub duration_s: f64,
}

/// Everything the layers need to know about one manoeuvre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManoeuvreInfo {
    /// Its name in the scenario files, on the command line and in the outputs:
    /// `pull-up`.
    pub name: &'static str,
    /// Its name as an identifier: `pull_up` (the bridge's profile codes, as
    /// `decoy bridge-layout --json` lists them for the Python client).
    pub ident: &'static str,
    /// One line for people.
    pub help: &'static str,
    /// Its parameters, each required or optional, in [`Parameter::ALL`]'s
    /// order (altitude and Mach first: every manoeuvre has them).
    pub parameters: &'static [(Parameter, Need)],
    /// What its rate does, in words (`turning`), for the manoeuvres with a
    /// [`Parameter::Rate`]: a run's description says "turning at 0.2 rad/s".
    pub rotation: Option<&'static str>,
    /// Its built-in profile on the decoy controller.
    pub builtin: BuiltinFlight,
}

/// The altitude of every built-in profile, m (one constant: the controller
/// computes the speed of sound there once, folded at compile time).
pub const BUILTIN_ALTITUDE_M: f64 = 9000.0;

impl Manoeuvre {
    /// Every manoeuvre, in declaration order.
    pub const ALL: [Manoeuvre; 4] = [
        Manoeuvre::Steady,
        Manoeuvre::Acceleration,
        Manoeuvre::PullUp,
        Manoeuvre::Turn,
    ];

    /// Its facts.
    pub const fn info(self) -> &'static ManoeuvreInfo {
        use Need::{Optional, Required};
        use Parameter as P;
        match self {
            Manoeuvre::Steady => &ManoeuvreInfo {
                name: "steady",
                ident: "steady",
                help: "Steady level flight",
                parameters: &[(P::Altitude, Required), (P::Mach, Required)],
                rotation: None,
                builtin: BuiltinFlight {
                    mach: 0.8,
                    final_mach: 0.8,
                    start_s: 0.0,
                    acceleration_mps2: 0.0,
                    duration_s: 0.0,
                },
            },
            Manoeuvre::Acceleration => &ManoeuvreInfo {
                name: "acceleration",
                ident: "acceleration",
                help: "Level acceleration from one Mach number to another",
                parameters: &[
                    (P::Altitude, Required),
                    (P::Mach, Required),
                    (P::FinalMach, Required),
                    (P::AccelerationStart, Required),
                    (P::Acceleration, Required),
                ],
                rotation: None,
                builtin: BuiltinFlight {
                    mach: 0.6,
                    final_mach: 0.8,
                    start_s: 2.0,
                    acceleration_mps2: 10.0,
                    duration_s: 0.0,
                },
            },
            Manoeuvre::PullUp => &ManoeuvreInfo {
                name: "pull-up",
                ident: "pull_up",
                help: "Pull-up: the flight path rotating up at a constant rate, then a climb",
                parameters: &[
                    (P::Altitude, Required),
                    (P::Mach, Required),
                    (P::Rate, Required),
                    (P::Start, Required),
                    (P::Duration, Required),
                ],
                rotation: Some("flight path rotating"),
                builtin: BuiltinFlight {
                    mach: 0.6,
                    final_mach: 0.6,
                    start_s: 2.0,
                    acceleration_mps2: 0.0,
                    duration_s: 5.0,
                },
            },
            Manoeuvre::Turn => &ManoeuvreInfo {
                name: "turn",
                ident: "turn",
                help: "Level coordinated turn at a constant rate",
                parameters: &[
                    (P::Altitude, Required),
                    (P::Mach, Required),
                    (P::Rate, Required),
                    (P::Start, Optional),
                ],
                rotation: Some("turning"),
                builtin: BuiltinFlight {
                    mach: 0.8,
                    final_mach: 0.8,
                    start_s: 0.0,
                    acceleration_mps2: 0.0,
                    duration_s: 0.0,
                },
            },
        }
    }

    /// Its name in the scenario files and on the command line (`pull-up`).
    pub const fn name(self) -> &'static str {
        self.info().name
    }

    /// Its name as an identifier (`pull_up`).
    pub const fn ident(self) -> &'static str {
        self.info().ident
    }

    /// One line for people.
    pub const fn help(self) -> &'static str {
        self.info().help
    }

    /// Its position in [`Manoeuvre::ALL`].
    pub const fn index(self) -> usize {
        self as usize - 1
    }

    /// Whether it needs `parameter`, or `None` if it has no such parameter.
    pub const fn need(self, parameter: Parameter) -> Option<Need> {
        let parameters = self.info().parameters;
        let mut i = 0;
        while i < parameters.len() {
            if parameters[i].0 as u8 == parameter as u8 {
                return Some(parameters[i].1);
            }
            i += 1;
        }
        None
    }

    /// True for the manoeuvres with a flight-path rotation rate
    /// ([`Parameter::Rate`]): on the link, their profile carries it.
    pub const fn has_rate(self) -> bool {
        self.need(Parameter::Rate).is_some()
    }

    /// The manoeuvre of that name (`pull-up`), if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The manoeuvre of that identifier (`pull_up`), if any.
    pub fn from_ident(ident: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.ident() == ident)
    }

    /// Its built-in profile's number on the decoy link (the variant index of
    /// `decoy_link::Profile` on the wire) and on the bridge (`Command::profile`):
    /// its discriminant, 1 + its position; 0 is the streamed profile
    /// ([`STREAMED_PROFILE_CODE`]).
    pub const fn profile_code(self) -> u16 {
        self as u16
    }

    /// The manoeuvre whose built-in profile has number `code`; `None` for the
    /// streamed profile and for numbers of no profile.
    pub const fn from_profile_code(code: u16) -> Option<Self> {
        if code == STREAMED_PROFILE_CODE || code as usize > Self::ALL.len() {
            None
        } else {
            Some(Self::ALL[code as usize - 1])
        }
    }
}

/// The number of the streamed profile (the kinematics from the State frames)
/// on the decoy link and the bridge; a manoeuvre's built-in profile is
/// [`Manoeuvre::profile_code`].
pub const STREAMED_PROFILE_CODE: u16 = 0;

// Checked when the crate compiles: `ALL` holds the variants in declaration
// order, every row's parameters follow `Parameter::ALL`'s order with altitude and
// Mach required, and a manoeuvre has a rotation wording exactly when it has a
// rate.
const _: () = {
    let mut i = 0;
    while i < Manoeuvre::ALL.len() {
        let m = Manoeuvre::ALL[i];
        assert!(
            m.index() == i && m.profile_code() as usize == i + 1,
            "Manoeuvre::ALL out of declaration order"
        );
        let info = m.info();
        assert!(
            matches!(m.need(Parameter::Altitude), Some(Need::Required))
                && matches!(m.need(Parameter::Mach), Some(Need::Required)),
            "every manoeuvre starts from an altitude and a Mach number"
        );
        assert!(
            m.has_rate() == info.rotation.is_some(),
            "a manoeuvre words its rotation exactly when it has a rate"
        );
        let mut last = 0;
        let mut j = 0;
        while j < info.parameters.len() {
            let p = info.parameters[j].0 as usize;
            assert!(
                j == 0 || p > last,
                "a manoeuvre's parameters follow Parameter::ALL's order, once each"
            );
            last = p;
            j += 1;
        }
        i += 1;
    }
    let mut k = 0;
    while k < Parameter::ALL.len() {
        assert!(
            Parameter::ALL[k] as usize == k,
            "Parameter::ALL out of declaration order"
        );
        k += 1;
    }
};

#[cfg(test)]
mod tests {
    use super::*;
    use serde::de::IntoDeserializer;
    use serde::de::value::{Error, U32Deserializer};

    /// `ALL` lists every variant: serde's derived enum knows them all, and has
    /// none at the position after the last of `ALL`.
    #[test]
    fn all_lists_every_variant() {
        for (i, m) in Manoeuvre::ALL.into_iter().enumerate() {
            let d: U32Deserializer<Error> = (i as u32).into_deserializer();
            assert_eq!(Manoeuvre::deserialize(d), Ok(m));
        }
        let past: U32Deserializer<Error> = (Manoeuvre::ALL.len() as u32).into_deserializer();
        assert!(Manoeuvre::deserialize(past).is_err());
    }

    /// Names, identifiers and profile codes are distinct and found again.
    #[test]
    fn names_and_codes_round_trip() {
        for m in Manoeuvre::ALL {
            assert_eq!(Manoeuvre::from_name(m.name()), Some(m));
            assert_eq!(Manoeuvre::from_ident(m.ident()), Some(m));
            assert_eq!(Manoeuvre::from_profile_code(m.profile_code()), Some(m));
            // Serde spells a manoeuvre as its name.
            let d: serde::de::value::StrDeserializer<Error> = m.name().into_deserializer();
            assert_eq!(Manoeuvre::deserialize(d), Ok(m));
            assert!(!m.help().is_empty());
        }
        assert_eq!(Manoeuvre::from_profile_code(STREAMED_PROFILE_CODE), None);
        assert_eq!(
            Manoeuvre::from_profile_code(Manoeuvre::ALL.len() as u16 + 1),
            None
        );
        assert_eq!(Manoeuvre::from_name("pull_up"), None);
        assert_eq!(Manoeuvre::from_ident("pull-up"), None);
        // The link's and the bridge's numbers of the first manoeuvres: a
        // profile's number on the wire never changes.
        for (m, code) in [
            (Manoeuvre::Steady, 1),
            (Manoeuvre::Acceleration, 2),
            (Manoeuvre::PullUp, 3),
            (Manoeuvre::Turn, 4),
        ] {
            assert_eq!(m.profile_code(), code, "{}", m.name());
        }
    }

    #[test]
    fn parameters_and_rates() {
        assert!(Manoeuvre::PullUp.has_rate() && Manoeuvre::Turn.has_rate());
        assert!(!Manoeuvre::Steady.has_rate() && !Manoeuvre::Acceleration.has_rate());
        assert_eq!(Manoeuvre::Turn.need(Parameter::Start), Some(Need::Optional));
        assert_eq!(
            Manoeuvre::PullUp.need(Parameter::Start),
            Some(Need::Required)
        );
        assert_eq!(Manoeuvre::Steady.need(Parameter::Duration), None);
        let keys = Parameter::ALL.map(Parameter::key);
        for (i, k) in keys.iter().enumerate() {
            assert!(!keys[..i].contains(k), "{k} twice");
        }
    }
}
