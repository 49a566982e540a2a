//! The manoeuvre envelope map on board: the file `envelope.limits_map` names
//! (`config/reference-system.limits.toml`), and the configuration's hash it is
//! checked against.
//!
//! The file is written by `decoy limits-table` from `decoy envelope`'s output
//! directories (docs/envelope.md, "On board"), never by hand: its
//! `config_hash` is the hash of the configuration those maps were made with
//! ([`config_hash`]). Loading a configuration that names it reads it, checks
//! that hash against the configuration's own and turns it into the
//! controller's [`LimitMap`]; a map made for another configuration is a
//! [`ConfigError::StaleLimits`] (the firmware's build fails the same way).

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use decoy_controller::{LimitGrid, LimitGridError, LimitMap, Limiting, Requirement};

use crate::error::{ConfigError, StaleLimits};
use crate::schema::SystemConfig;

/// How a hash is written: this prefix, then 64 lower-case hex digits.
pub const HASH_PREFIX: &str = "sha256:";

/// The hash of everything a map of `config` depends on: SHA-256 of the JSON
/// of its tables (`serde_json`, floats in their shortest round-trip form) and
/// of its aerodynamic table's rows, without `envelope.limits_map` (the map
/// does not depend on where it is kept) and without the embedded model's
/// discretisation (`solver.segments_embedded`, `solver.grading_ratio_embedded`:
/// the map is made on the host model, and a firmware variant of another
/// segment count carries the same map). Comments, layout and the order of
/// keys in the files do not change it; any other value does.
pub fn config_hash(config: &SystemConfig) -> String {
    let mut tables = config.clone();
    tables.envelope.limits_map = None;
    tables.limits = None;
    tables.stale_limits = None;
    tables.solver.segments_embedded = 0;
    tables.solver.grading_ratio_embedded = 0.0;
    let text = serde_json::to_string(&(&tables, &config.aero_rows))
        .expect("a validated configuration serialises");
    let digest = Sha256::digest(text.as_bytes());
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    format!("{HASH_PREFIX}{hex}")
}

impl SystemConfig {
    /// `Ok` unless the envelope map the configuration names was made for
    /// another configuration: then [`ConfigError::StaleLimits`]. What must
    /// carry the map (the firmware's build) calls this; a host run loads such
    /// a configuration without the map (every limit unknown) and may warn.
    pub fn check_limits(&self) -> Result<(), ConfigError> {
        match &self.stale_limits {
            Some(stale) => Err(stale.error()),
            None => Ok(()),
        }
    }
}

/// The map file, as written and read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsFile {
    /// [`config_hash`] of the configuration the maps were made with.
    pub config_hash: String,
    /// The pull-up's map (rad/s).
    #[serde(rename = "pull-up", default, skip_serializing_if = "Option::is_none")]
    pub pull_up: Option<LimitsGrid>,
    /// The turn's map (rad/s).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn: Option<LimitsGrid>,
    /// The acceleration's map (m/s^2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acceleration: Option<LimitsGrid>,
}

/// One manoeuvre's map in the file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LimitsGrid {
    /// The limit's unit: `rad/s` (pull-up, turn) or `m/s^2` (acceleration).
    pub unit: String,
    /// How the map was made (the model, the onset, the tolerance): words for
    /// the reader.
    pub made_with: String,
    /// The grid's altitudes, m, ascending.
    pub altitudes_m: Vec<f64>,
    /// The grid's Mach numbers, ascending.
    pub machs: Vec<f64>,
    /// The limits, a row per altitude, a value per Mach number.
    pub limits: Vec<Vec<f64>>,
    /// What limits each cell, the same shape: a requirement's name
    /// (`posture`, `collision`, `tension`, `exhaust`) or the envelope bound
    /// that caps it (`load factor`, `body rate`, `acceleration bound`).
    pub limiting: Vec<Vec<String>>,
    /// The longest the map's manoeuvre lasts from its entry, s (the pull-up's
    /// rotation with its onsets; the turn's whole run; absent for the
    /// acceleration, whose extent is a Mach gain): how long the map's verdict
    /// covers a manoeuvre on board (docs/protocol.md §3, "Advisories from the
    /// map"). Absent: the map covers nothing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub manoeuvre_s: Option<f64>,
    /// How long the map's runs fly on after the manoeuvre ends, s (its
    /// aftermath; 0 for the turn, whose run ends turning).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub aftermath_s: Option<f64>,
}

/// The envelope bounds a cell's limit may be capped by, as the map names them.
pub const BOUND_NAMES: [&str; 3] = ["load factor", "body rate", "acceleration bound"];

impl LimitsFile {
    /// The file `name`'s `text`, parsed (not yet checked).
    pub fn parse(name: &str, text: &str) -> Result<Self, ConfigError> {
        toml::from_str(text).map_err(|e| {
            let span = e.span();
            crate::error::toml_error(name, text, e.message(), span)
        })
    }

    /// The file's text: a header saying what it is and how it is made again,
    /// then the tables.
    pub fn to_toml(&self, header: &str) -> String {
        let body = toml::to_string(self).expect("a map serialises");
        let mut text = String::new();
        for line in header.lines() {
            text.push_str("# ");
            text.push_str(line);
            text.push('\n');
        }
        text.push('\n');
        text.push_str(&body);
        text
    }

    /// The controller's map, checked: the hash is `config`'s
    /// ([`ConfigError::StaleLimits`] otherwise), then as [`LimitsFile::to_grids`].
    /// `name` names the file in messages.
    pub fn to_map(&self, name: &str, config: &SystemConfig) -> Result<LimitMap, ConfigError> {
        if let Some(stale) = self.stale_for(name, config) {
            return Err(stale.error());
        }
        self.to_grids(name)
    }

    /// Why the file is not `config`'s map (its hash is another's), if it is not.
    pub fn stale_for(&self, name: &str, config: &SystemConfig) -> Option<StaleLimits> {
        let expected = config_hash(config);
        (self.config_hash != expected).then(|| StaleLimits {
            file: name.to_owned(),
            config: config.source.clone(),
            found: self.config_hash.clone(),
            expected,
        })
    }

    /// The controller's map, whatever the hash: each grid's unit is its
    /// manoeuvre's, its shape fits the controller
    /// ([`decoy_controller::LIMIT_AXIS_CAPACITY`] and
    /// [`decoy_controller::LIMIT_CELL_CAPACITY`]) and its names are known.
    pub fn to_grids(&self, name: &str) -> Result<LimitMap, ConfigError> {
        let grid = |key: &str, unit: &str, grid: &Option<LimitsGrid>| match grid {
            None => Ok(LimitGrid::EMPTY),
            Some(g) => g.to_grid(name, key, unit),
        };
        Ok(LimitMap {
            pull_up: grid("pull-up", "rad/s", &self.pull_up)?,
            turn: grid("turn", "rad/s", &self.turn)?,
            acceleration: grid("acceleration", "m/s^2", &self.acceleration)?,
        })
    }
}

impl LimitsGrid {
    /// The controller's grid of this table `[key]`, whose unit must be `unit`.
    fn to_grid(&self, file: &str, key: &str, unit: &str) -> Result<LimitGrid, ConfigError> {
        let invalid = |field: &str, message: String| ConfigError::Invalid {
            file: file.to_owned(),
            field: format!("{key}.{field}"),
            message,
        };
        if self.unit != unit {
            return Err(invalid(
                "unit",
                format!("= \"{}\" must be \"{unit}\"", self.unit),
            ));
        }
        let rows = self.altitudes_m.len();
        let columns = self.machs.len();
        let shaped =
            |lengths: Vec<usize>| lengths.len() == rows && lengths.iter().all(|&n| n == columns);
        if !shaped(self.limits.iter().map(Vec::len).collect()) {
            return Err(invalid(
                "limits",
                format!(
                    "must have a row per altitude ({rows}) of a value per Mach number ({columns})"
                ),
            ));
        }
        if !shaped(self.limiting.iter().map(Vec::len).collect()) {
            return Err(invalid(
                "limiting",
                format!(
                    "must have a row per altitude ({rows}) of a name per Mach number ({columns})"
                ),
            ));
        }
        let mut cells = Vec::with_capacity(rows * columns);
        for (limits, names) in self.limits.iter().zip(&self.limiting) {
            for (&limit, name) in limits.iter().zip(names) {
                let limiting = match Requirement::ALL.iter().find(|r| r.name() == name) {
                    Some(&r) => Limiting::Requirement(r),
                    None if BOUND_NAMES.contains(&name.as_str()) => Limiting::Bound,
                    None => {
                        return Err(invalid(
                            "limiting",
                            format!(
                                "has \"{name}\": not a requirement ({}) nor a bound ({})",
                                Requirement::ALL.map(|r| r.name()).join(", "),
                                BOUND_NAMES.join(", ")
                            ),
                        ));
                    }
                };
                cells.push((limit as f32, limiting));
            }
        }
        let narrow = |axis: &[f64]| axis.iter().map(|&v| v as f32).collect::<Vec<f32>>();
        let grid = LimitGrid::new(&narrow(&self.altitudes_m), &narrow(&self.machs), &cells)
            .map_err(|e| {
                let field = match e {
                    LimitGridError::AxisSize | LimitGridError::NotAscending => {
                        "altitudes_m or machs"
                    }
                    LimitGridError::CellCount | LimitGridError::Limit => "limits",
                };
                invalid(field, e.to_string())
            })?;
        let seconds = |field: &str, v: Option<f64>| match v {
            None => Ok(0.0),
            Some(s) if s.is_finite() && (0.0..=1e6).contains(&s) => Ok(s as f32),
            Some(s) => Err(invalid(field, format!("= {s} must be between 0 and 1e6 s"))),
        };
        match (self.manoeuvre_s, self.aftermath_s) {
            (None, None) => Ok(grid),
            (Some(_), None) | (None, Some(_)) => Err(invalid(
                "manoeuvre_s",
                "and aftermath_s come together or not at all".to_owned(),
            )),
            (m, a) => Ok(grid.with_cover(seconds("manoeuvre_s", m)?, seconds("aftermath_s", a)?)),
        }
    }
}
