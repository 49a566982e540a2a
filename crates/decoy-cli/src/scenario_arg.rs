//! `--scenario NAME|FILE`: a shipped scenario's name, or the path of a scenario
//! file. clap lists the shipped scenarios, one per `decoy_sim::ScenarioKind` and
//! named after it, with the kind's help (`decoy_schema`'s table for the
//! manoeuvres), and takes any other value as a path: `Scenario::load` tells the
//! two apart and names the shipped scenarios when it is neither.

use std::ffi::OsStr;

use clap::builder::{PossibleValue, StringValueParser, TypedValueParser};
use decoy_sim::ScenarioKind;

/// The value parser of `--scenario`.
#[derive(Clone, Copy, Debug)]
pub struct ScenarioArg;

impl TypedValueParser for ScenarioArg {
    type Value = String;

    /// Any text: a name or a path.
    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<String, clap::Error> {
        StringValueParser::new().parse_ref(cmd, arg, value)
    }

    /// The shipped scenarios, for the help (not a restriction).
    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(ScenarioKind::ALL.into_iter().map(|kind| {
            PossibleValue::new(kind.name()).help(kind.help())
        })))
    }
}
