//! The columns of every CSV file the tools write, each described once.
//!
//! A [`CsvFile`] lists its [`Column`]s in file order: the column's name (units
//! in the name, `tension_connection_N`), its unit, what it means, and the
//! [`Quantity`] it holds, by which a writer produces the column's value. Every
//! header is generated from this list ([`CsvFile::header`]), every writer
//! writes its rows in this order (each writer's tests check its rows against
//! its file's list), `decoy bridge-layout --json` exports the list (the Python
//! client reads its column names from there), and docs/outputs.md's column
//! tables are generated from it ([`CsvFile::markdown_table`]; a test keeps them
//! equal).
//!
//! The per-requirement columns (`posture_level`, `posture_margin_deg`,
//! `posture_violation_in_s`, ...) are generated from the requirement list
//! ([`for_each_requirement!`](crate::for_each_requirement)), in its order.

use core::fmt;

use serde::ser::SerializeStruct;
use serde::{Serialize, Serializer};

use crate::requirement::{REQUIREMENT_COUNT, Requirement};

/// What a column holds: the same quantity has the same name in every file
/// (docs/outputs.md, "One output contract"); its description may say how a
/// file measures it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Quantity {
    /// Time, s.
    Time,
    /// A frame's sequence number.
    Seq,
    /// Cable tension at the connection point (joint 0), N.
    TensionConnection,
    /// Cable tension at the towing point (joint N), N.
    TensionTow,
    /// Decoy CG behind the aircraft reference point (flight-path frame), m.
    DecoyCgBehind,
    /// Decoy CG left of the flight path (flight-path frame), m.
    DecoyCgLateral,
    /// Decoy CG below the flight path (flight-path frame), m.
    DecoyCgBelow,
    /// Decoy roll, deg.
    DecoyRoll,
    /// Decoy pitch, deg.
    DecoyPitch,
    /// Decoy yaw, deg.
    DecoyYaw,
    /// Decoy total angle of attack, deg.
    DecoyAoa,
    /// Cable clearance to the exhaust plume, m.
    CableExhaustClearance,
    /// Where on the cable the closest point to the plume is, m.
    CableExhaustClosestAlong,
    /// Decoy CG clearance to the aircraft's collision capsule, m.
    DecoyAircraftClearance,
    /// Aircraft ground speed, m/s.
    AircraftSpeed,
    /// Aircraft reference point altitude, m.
    AircraftAltitude,
    /// The aircraft's load factor, g.
    AircraftLoadFactor,
    /// An output's status flags.
    Flags,
    /// RK4 steps of a frame.
    Rk4Steps,
    /// Instructions of a frame.
    Instructions,
    /// A frame's round trip, µs.
    LatencyUs,
    /// The host's connection tension, N.
    HostTensionConnection,
    /// The host's towing-point tension, N.
    HostTensionTow,
    /// The host's decoy pitch, deg.
    HostDecoyPitch,
    /// The host's decoy angle of attack, deg.
    HostDecoyAoa,
    /// Connection tension, controller minus host, N.
    TensionConnectionDiff,
    /// Towing-point tension, controller minus host, N.
    TensionTowDiff,
    /// Look-ahead RK4 steps of a frame's slice.
    PredictionSteps,
    /// Instructions of the decoy management between two outputs.
    ManagementInstructions,
    /// A requirement's level (0 normal, 1 caution, 2 warning, 3 violated).
    Level(Requirement),
    /// A requirement's margin, in its file unit.
    Margin(Requirement),
    /// The onboard controller's advisory bits (the look-ahead's and the map's).
    Advisories,
    /// The look-ahead's predicted time to a requirement's violation, s.
    ViolationIn(Requirement),
    /// The envelope map's largest clear pull-up rate at the flight condition, rad/s.
    LimitPullUp,
    /// The envelope map's largest clear turn rate at the flight condition, rad/s.
    LimitTurn,
    /// The envelope map's largest clear along-path acceleration there, m/s².
    LimitAcceleration,
    /// The floor of the pull-up's limit (the smallest of the cells around), rad/s.
    LimitFloorPullUp,
    /// The floor of the turn's limit, rad/s.
    LimitFloorTurn,
    /// The floor of the acceleration's limit, m/s².
    LimitFloorAcceleration,
    /// A joint's index (cable snapshots).
    Joint,
    /// A joint's distance along the cable from the connection point, m.
    Along,
    /// A joint behind the aircraft reference point (flight-path frame), m.
    Behind,
    /// A joint left of the flight path (flight-path frame), m.
    Lateral,
    /// A joint below the flight path (flight-path frame), m.
    Below,
    /// The cable tension at a joint, N.
    Tension,
    /// Aircraft reference point, NED: north, east, down, m.
    PositionNed(Axis),
    /// Velocity over the ground, NED, m/s.
    VelocityNed(Axis),
    /// Acceleration, NED, m/s².
    AccelerationNed(Axis),
    /// Attitude quaternion component: 0 w, 1 x, 2 y, 3 z.
    Attitude(u8),
    /// Body rate (FRD), rad/s.
    BodyRate(Axis),
    /// Body angular acceleration (FRD), rad/s².
    BodyAngularAcceleration(Axis),
    /// A flight simulation's own quantity of the Python client's trajectory
    /// (the key of its `AircraftState.extra`: the column's name).
    FlightTest,
}

/// The axis of a vector quantity: 0, 1, 2 (north, east, down; or the body's x,
/// y, z).
pub type Axis = u8;

impl Quantity {
    /// The quantity's key in the layout JSON (`tension_connection`, `margin`,
    /// `position_ned`); with [`Quantity::requirement`] and [`Quantity::index`]
    /// it names the quantity.
    pub const fn key(self) -> &'static str {
        match self {
            Quantity::Time => "time",
            Quantity::Seq => "seq",
            Quantity::TensionConnection => "tension_connection",
            Quantity::TensionTow => "tension_tow",
            Quantity::DecoyCgBehind => "decoy_cg_behind",
            Quantity::DecoyCgLateral => "decoy_cg_lateral",
            Quantity::DecoyCgBelow => "decoy_cg_below",
            Quantity::DecoyRoll => "decoy_roll",
            Quantity::DecoyPitch => "decoy_pitch",
            Quantity::DecoyYaw => "decoy_yaw",
            Quantity::DecoyAoa => "decoy_aoa",
            Quantity::CableExhaustClearance => "cable_exhaust_clearance",
            Quantity::CableExhaustClosestAlong => "cable_exhaust_closest_along",
            Quantity::DecoyAircraftClearance => "decoy_aircraft_clearance",
            Quantity::AircraftSpeed => "aircraft_speed",
            Quantity::AircraftAltitude => "aircraft_altitude",
            Quantity::AircraftLoadFactor => "aircraft_load_factor",
            Quantity::Flags => "flags",
            Quantity::Rk4Steps => "rk4_steps",
            Quantity::Instructions => "instructions",
            Quantity::LatencyUs => "latency",
            Quantity::HostTensionConnection => "host_tension_connection",
            Quantity::HostTensionTow => "host_tension_tow",
            Quantity::HostDecoyPitch => "host_decoy_pitch",
            Quantity::HostDecoyAoa => "host_decoy_aoa",
            Quantity::TensionConnectionDiff => "tension_connection_diff",
            Quantity::TensionTowDiff => "tension_tow_diff",
            Quantity::PredictionSteps => "prediction_steps",
            Quantity::ManagementInstructions => "management_instructions",
            Quantity::Level(_) => "level",
            Quantity::Margin(_) => "margin",
            Quantity::Advisories => "advisories",
            Quantity::ViolationIn(_) => "violation_in",
            Quantity::LimitPullUp => "limit_pull_up",
            Quantity::LimitTurn => "limit_turn",
            Quantity::LimitAcceleration => "limit_acceleration",
            Quantity::LimitFloorPullUp => "limit_floor_pull_up",
            Quantity::LimitFloorTurn => "limit_floor_turn",
            Quantity::LimitFloorAcceleration => "limit_floor_acceleration",
            Quantity::Joint => "joint",
            Quantity::Along => "along",
            Quantity::Behind => "behind",
            Quantity::Lateral => "lateral",
            Quantity::Below => "below",
            Quantity::Tension => "tension",
            Quantity::PositionNed(_) => "position_ned",
            Quantity::VelocityNed(_) => "velocity_ned",
            Quantity::AccelerationNed(_) => "acceleration_ned",
            Quantity::Attitude(_) => "attitude",
            Quantity::BodyRate(_) => "body_rate",
            Quantity::BodyAngularAcceleration(_) => "body_angular_acceleration",
            Quantity::FlightTest => "flight_test",
        }
    }

    /// The requirement of a per-requirement quantity.
    pub const fn requirement(self) -> Option<Requirement> {
        match self {
            Quantity::Level(r) | Quantity::Margin(r) | Quantity::ViolationIn(r) => Some(r),
            _ => None,
        }
    }

    /// The component of a vector quantity.
    pub const fn index(self) -> Option<u8> {
        match self {
            Quantity::PositionNed(i)
            | Quantity::VelocityNed(i)
            | Quantity::AccelerationNed(i)
            | Quantity::Attitude(i)
            | Quantity::BodyRate(i)
            | Quantity::BodyAngularAcceleration(i) => Some(i),
            _ => None,
        }
    }
}

/// One column of a CSV file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Column {
    /// What it holds.
    pub quantity: Quantity,
    /// Its name in the header (the unit at its end: `tension_connection_N`).
    pub name: &'static str,
    /// Its unit (empty for a count, a code or a ratio).
    pub unit: &'static str,
    /// What it means, one sentence fragment (docs/outputs.md shows it).
    pub description: &'static str,
}

impl Column {
    const fn new(
        quantity: Quantity,
        name: &'static str,
        unit: &'static str,
        description: &'static str,
    ) -> Self {
        Column {
            quantity,
            name,
            unit,
            description,
        }
    }

    /// The same column with another description (the same quantity measured
    /// another way in another file).
    const fn described(self, description: &'static str) -> Self {
        Column {
            description,
            ..self
        }
    }
}

impl Serialize for Column {
    /// `{"name", "unit", "quantity", "requirement", "index", "description"}`
    /// (`requirement` and `index` null where they do not apply).
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut s = serializer.serialize_struct("Column", 6)?;
        s.serialize_field("name", self.name)?;
        s.serialize_field("unit", self.unit)?;
        s.serialize_field("quantity", self.quantity.key())?;
        s.serialize_field("requirement", &self.quantity.requirement())?;
        s.serialize_field("index", &self.quantity.index())?;
        s.serialize_field("description", self.description)?;
        s.end()
    }
}

/// A CSV file the tools write: who writes it and its columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct CsvFile {
    /// The schema's name for it (`simulate_timeseries`).
    pub id: &'static str,
    /// The file's name (`timeseries.csv`).
    pub file: &'static str,
    /// What writes it (`decoy simulate`).
    pub written_by: &'static str,
    /// Its columns, in file order.
    pub columns: &'static [Column],
}

impl CsvFile {
    /// The header line (without its newline): the names joined by commas.
    pub fn header(&self) -> Header {
        Header(self.columns)
    }

    /// The columns' names, in file order.
    pub fn names(&self) -> impl Iterator<Item = &'static str> {
        self.columns.iter().map(|c| c.name)
    }

    /// The position of the column holding `quantity`.
    pub fn position(&self, quantity: Quantity) -> Option<usize> {
        self.columns.iter().position(|c| c.quantity == quantity)
    }

    /// The Markdown table of the columns (`| column | unit | meaning |`, a row
    /// per column, each line ended by a newline), as docs/outputs.md shows it.
    pub fn markdown_table(&self) -> MarkdownTable {
        MarkdownTable(self.columns)
    }
}

/// A file's header line ([`CsvFile::header`]), written by its `Display`.
#[derive(Clone, Copy, Debug)]
pub struct Header(&'static [Column]);

impl fmt::Display for Header {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (k, c) in self.0.iter().enumerate() {
            if k > 0 {
                f.write_str(",")?;
            }
            f.write_str(c.name)?;
        }
        Ok(())
    }
}

/// A file's column table in Markdown ([`CsvFile::markdown_table`]).
#[derive(Clone, Copy, Debug)]
pub struct MarkdownTable(&'static [Column]);

impl fmt::Display for MarkdownTable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("| column | unit | meaning |\n|---|---|---|\n")?;
        for c in self.0 {
            writeln!(f, "| `{}` | {} | {} |", c.name, c.unit, c.description)?;
        }
        Ok(())
    }
}

/// The columns of `parts`, one after the other, as an array of `N` (`N` their
/// total: checked when the constant is evaluated).
const fn join<const N: usize>(parts: &[&[Column]]) -> [Column; N] {
    let mut out = [Column::new(Quantity::Time, "", "", ""); N];
    let mut n = 0;
    let mut p = 0;
    while p < parts.len() {
        let mut i = 0;
        while i < parts[p].len() {
            out[n] = parts[p][i];
            n += 1;
            i += 1;
        }
        p += 1;
    }
    assert!(n == N, "join: the parts do not have N columns");
    out
}

// ---------------------------------------------------------------- the columns

const TIME: Column = Column::new(Quantity::Time, "t_s", "s", "simulation time");
const SEQ: Column = Column::new(Quantity::Seq, "seq", "", "frame sequence number");
const TENSION_CONNECTION: Column = Column::new(
    Quantity::TensionConnection,
    "tension_connection_N",
    "N",
    "cable tension at the connection point (joint 0), positive when pulling",
);
const TENSION_TOW: Column = Column::new(
    Quantity::TensionTow,
    "tension_tow_N",
    "N",
    "cable tension at the decoy's towing point (joint N)",
);
const DECOY_CG: [Column; 3] = [
    Column::new(
        Quantity::DecoyCgBehind,
        "decoy_cg_behind_m",
        "m",
        "decoy CG behind the aircraft reference point (flight-path frame)",
    ),
    Column::new(
        Quantity::DecoyCgLateral,
        "decoy_cg_lateral_m",
        "m",
        "decoy CG to the left of the flight path (the outside of a right turn; see \"Frames and signs\")",
    ),
    Column::new(
        Quantity::DecoyCgBelow,
        "decoy_cg_below_m",
        "m",
        "decoy CG below the flight path",
    ),
];
const DECOY_ROLL: Column = Column::new(
    Quantity::DecoyRoll,
    "decoy_roll_deg",
    "deg",
    "decoy roll relative to NED",
);
const DECOY_PITCH: Column = Column::new(
    Quantity::DecoyPitch,
    "decoy_pitch_deg",
    "deg",
    "decoy pitch relative to NED, positive nose-up",
);
const DECOY_YAW: Column = Column::new(
    Quantity::DecoyYaw,
    "decoy_yaw_deg",
    "deg",
    "decoy yaw (heading) relative to NED, unwrapped (continuous, may pass ±180)",
);
/// Roll, pitch and yaw as the controller reports them (`decoy_euler_rel_rad`).
const DECOY_EULER_REL: [Column; 3] = [
    DECOY_ROLL.described(
        "decoy roll relative to the flight-path frame (the controller's `decoy_euler_rel_rad`)",
    ),
    DECOY_PITCH.described("decoy pitch relative to the flight-path frame, positive nose-up"),
    DECOY_YAW.described("decoy yaw relative to the flight-path frame (not unwrapped)"),
];
const DECOY_AOA: Column = Column::new(
    Quantity::DecoyAoa,
    "decoy_aoa_deg",
    "deg",
    "decoy total angle of attack",
);
const CABLE_EXHAUST_CLEARANCE: Column = Column::new(
    Quantity::CableExhaustClearance,
    "cable_exhaust_clearance_m",
    "m",
    "smallest distance from the cable (every joint and segment midpoint) to the exhaust plume's surface; negative inside the plume",
);
const CABLE_EXHAUST_CLOSEST_ALONG: Column = Column::new(
    Quantity::CableExhaustClosestAlong,
    "cable_exhaust_closest_along_m",
    "m",
    "where on the cable that closest point is, as distance from the connection point",
);
const DECOY_AIRCRAFT_CLEARANCE: Column = Column::new(
    Quantity::DecoyAircraftClearance,
    "decoy_aircraft_clearance_m",
    "m",
    "distance from the decoy CG to the surface of the aircraft's collision capsule; negative inside",
);
const AIRCRAFT_SPEED: Column = Column::new(
    Quantity::AircraftSpeed,
    "aircraft_speed_mps",
    "m/s",
    "aircraft ground speed",
);
const AIRCRAFT_ALTITUDE: Column = Column::new(
    Quantity::AircraftAltitude,
    "aircraft_altitude_m",
    "m",
    "aircraft reference point altitude",
);
const FLAGS: Column = Column::new(
    Quantity::Flags,
    "flags",
    "",
    "the output's status flags (docs/protocol.md, \"Status flags\": 1 trimmed, 4 over tension, 8 cable in the plume, 16 decoy near the aircraft, 64 recovered, 128 initialising, 256 outside the envelope, 512 step-limited)",
);
const RK4_STEPS: Column = Column::new(
    Quantity::Rk4Steps,
    "rk4_steps",
    "",
    "RK4 steps the controller took for the frame (0 for the trim)",
);
const INSTRUCTIONS: Column = Column::new(
    Quantity::Instructions,
    "instructions",
    "",
    "instructions the firmware spent on the frame (SysTick under `-icount shift=0`: exact; the trim frame includes the trim); 0 from a host controller",
);

/// Level and margin of every requirement, in the requirement list's order.
const LEVELS_AND_MARGINS: [Column; 2 * REQUIREMENT_COUNT] = {
    macro_rules! levels_and_margins {
        ($(($variant:ident, $field:ident, $unit:literal, $file_unit:literal,
            $title:literal, $margin:literal)),* $(,)?) => {
            [$(
                Column::new(
                    Quantity::Level(Requirement::$variant),
                    concat!(stringify!($field), "_level"),
                    "",
                    concat!(
                        "decoy-management level of the ", stringify!($field),
                        " requirement: 0 normal, 1 caution, 2 warning, 3 violated (thresholds and hysteresis from `[management.",
                        stringify!($field), "]`; docs/management.md)"
                    ),
                ),
                Column::new(
                    Quantity::Margin(Requirement::$variant),
                    concat!(stringify!($field), "_margin_", $file_unit),
                    $file_unit,
                    concat!(stringify!($field), " margin: ", $margin, "; negative: violated"),
                ),
            )*]
        };
    }
    crate::for_each_requirement!(levels_and_margins)
};

const ADVISORIES: Column = Column::new(
    Quantity::Advisories,
    "advisories",
    "",
    "the onboard controller's advisory bits, bit k (value 2^k) for the k-th requirement of docs/management.md's table: \"continuing this manoeuvre violates it\" (the look-ahead's, within its horizon, or the map on board's); bit 7 (128) when the map on board advises",
);

/// The look-ahead's predicted time to each requirement's violation.
const VIOLATIONS_IN: [Column; REQUIREMENT_COUNT] = {
    macro_rules! violations_in {
        ($(($variant:ident, $field:ident, $unit:literal, $file_unit:literal,
            $title:literal, $margin:literal)),* $(,)?) => {
            [$(
                Column::new(
                    Quantity::ViolationIn(Requirement::$variant),
                    concat!(stringify!($field), "_violation_in_s"),
                    "s",
                    concat!(
                        "the look-ahead's predicted time until the ", stringify!($field),
                        " requirement is violated; -1 when none is predicted"
                    ),
                ),
            )*]
        };
    }
    crate::for_each_requirement!(violations_in)
};

const SIMULATE_TIMESERIES_COLUMNS: [Column; 15 + 3 * REQUIREMENT_COUNT + 1] = join(&[
    &[TIME, TENSION_CONNECTION, TENSION_TOW],
    &DECOY_CG,
    &[
        DECOY_ROLL,
        DECOY_PITCH,
        DECOY_YAW,
        DECOY_AOA,
        CABLE_EXHAUST_CLEARANCE,
        CABLE_EXHAUST_CLOSEST_ALONG,
        DECOY_AIRCRAFT_CLEARANCE,
        AIRCRAFT_SPEED,
        AIRCRAFT_ALTITUDE,
    ],
    &LEVELS_AND_MARGINS,
    &[ADVISORIES],
    &VIOLATIONS_IN,
]);

/// `decoy simulate`'s `timeseries.csv`: one row every 10 ms of simulated time.
pub const SIMULATE_TIMESERIES: CsvFile = CsvFile {
    id: "simulate_timeseries",
    file: "timeseries.csv",
    written_by: "decoy simulate",
    columns: &SIMULATE_TIMESERIES_COLUMNS,
};

/// `decoy simulate`'s `cable.csv`: the cable's shape and tension every 1 s.
pub const SIMULATE_CABLE: CsvFile = CsvFile {
    id: "simulate_cable",
    file: "cable.csv",
    written_by: "decoy simulate",
    columns: &[
        TIME.described("snapshot time"),
        Column::new(
            Quantity::Joint,
            "joint",
            "",
            "joint index, 0 = connection point, N = towing point",
        ),
        Column::new(
            Quantity::Along,
            "along_m",
            "m",
            "distance along the cable from the connection point",
        ),
        Column::new(
            Quantity::Behind,
            "behind_m",
            "m",
            "joint behind the aircraft reference point, flight-path frame (as `decoy_cg_behind_m`)",
        ),
        Column::new(
            Quantity::Lateral,
            "lateral_m",
            "m",
            "joint to the left of the flight path (as `decoy_cg_lateral_m`)",
        ),
        Column::new(
            Quantity::Below,
            "below_m",
            "m",
            "joint below the flight path (as `decoy_cg_below_m`)",
        ),
        Column::new(
            Quantity::Tension,
            "tension_N",
            "N",
            "cable tension at the joint",
        ),
    ],
};

/// The columns of a controller's output frame in `decoy hil`'s, `decoy feed`'s
/// and the Python client's time series, after `t_s` and `seq`.
const OUTPUT_FRAME: [Column; 11] = join(&[
    &[TENSION_CONNECTION, TENSION_TOW],
    &DECOY_CG,
    &DECOY_EULER_REL,
    &[
        DECOY_AOA,
        CABLE_EXHAUST_CLEARANCE,
        DECOY_AIRCRAFT_CLEARANCE.described(
            "distance from the decoy CG to the surface of the aircraft's collision capsule; negative inside (the position of the cable's point closest to the plume is not reported by the controller)",
        ),
    ],
]);

/// The envelope map's limits an Output reports (docs/protocol.md, "Limits").
const LIMITS: [Column; 6] = [
    Column::new(
        Quantity::LimitPullUp,
        "limit_pull_up_radps",
        "rad/s",
        "the controller's envelope map: the largest clear pull-up rate at the frame's altitude and Mach number (interpolated; -1 where not known)",
    ),
    Column::new(
        Quantity::LimitTurn,
        "limit_turn_radps",
        "rad/s",
        "the controller's envelope map: the largest clear level-turn rate there (-1 where not known)",
    ),
    Column::new(
        Quantity::LimitAcceleration,
        "limit_acceleration_mps2",
        "m/s²",
        "the controller's envelope map: the largest clear along-path acceleration there (-1 where not known)",
    ),
    Column::new(
        Quantity::LimitFloorPullUp,
        "limit_floor_pull_up_radps",
        "rad/s",
        "the floor of the pull-up's limit: the smallest of the map's cells around the flight condition, the value to cue against (-1 where not known)",
    ),
    Column::new(
        Quantity::LimitFloorTurn,
        "limit_floor_turn_radps",
        "rad/s",
        "the floor of the turn's limit (-1 where not known)",
    ),
    Column::new(
        Quantity::LimitFloorAcceleration,
        "limit_floor_acceleration_mps2",
        "m/s²",
        "the floor of the acceleration's limit (-1 where not known)",
    ),
];

const HIL_TIMESERIES_COLUMNS: [Column; 26 + 3 * REQUIREMENT_COUNT + 1 + 6] = join(&[
    &[TIME.described("frame time"), SEQ],
    &OUTPUT_FRAME,
    &[
        AIRCRAFT_SPEED.described("ground speed of the frame sent"),
        AIRCRAFT_ALTITUDE.described("altitude of the frame sent"),
        FLAGS,
        RK4_STEPS,
        INSTRUCTIONS,
        Column::new(
            Quantity::HostTensionConnection,
            "host_tension_connection_N",
            "N",
            "the host's connection tension (f64, the same frames and model)",
        ),
        Column::new(
            Quantity::HostTensionTow,
            "host_tension_tow_N",
            "N",
            "the host's towing-point tension",
        ),
        Column::new(
            Quantity::HostDecoyPitch,
            "host_decoy_pitch_deg",
            "deg",
            "the host's decoy pitch (flight-path frame)",
        ),
        Column::new(
            Quantity::HostDecoyAoa,
            "host_decoy_aoa_deg",
            "deg",
            "the host's decoy angle of attack",
        ),
        Column::new(
            Quantity::TensionConnectionDiff,
            "tension_connection_diff_N",
            "N",
            "connection tension, controller minus host",
        ),
        Column::new(
            Quantity::TensionTowDiff,
            "tension_tow_diff_N",
            "N",
            "towing-point tension, controller minus host",
        ),
        Column::new(
            Quantity::PredictionSteps,
            "prediction_steps",
            "",
            "the look-ahead's RK4 steps in the slice that ran since the previous output (the previous frame's, run after its answer was sent)",
        ),
        Column::new(
            Quantity::ManagementInstructions,
            "management_instructions",
            "",
            "the instructions of the decoy management since the previous output (that slice, then this frame's monitors; not in `instructions`)",
        ),
    ],
    &LEVELS_AND_MARGINS,
    &[ADVISORIES],
    &VIOLATIONS_IN,
    &LIMITS,
]);

/// `decoy hil`'s and `decoy feed`'s `timeseries.csv`: one row per output frame
/// (every 10 ms), the controller's outputs beside the host's.
pub const HIL_TIMESERIES: CsvFile = CsvFile {
    id: "hil_timeseries",
    file: "timeseries.csv",
    written_by: "decoy hil, decoy feed",
    columns: &HIL_TIMESERIES_COLUMNS,
};

const CLIENT_TIMESERIES_COLUMNS: [Column; 20 + 2 * REQUIREMENT_COUNT + 1] = join(&[
    &[TIME.described("frame time"), SEQ],
    &OUTPUT_FRAME,
    &[
        AIRCRAFT_SPEED.described("ground speed of the state sent"),
        AIRCRAFT_ALTITUDE.described("altitude of the state sent"),
        Column::new(
            Quantity::AircraftLoadFactor,
            "aircraft_load_factor",
            "g",
            "the flight simulation's load factor (the trajectory's `load_factor`; NaN without one)",
        ),
        FLAGS,
        RK4_STEPS,
        INSTRUCTIONS,
        Column::new(
            Quantity::LatencyUs,
            "latency_us",
            "µs",
            "the frame's round trip from Python (request sent to answer received)",
        ),
    ],
    &LEVELS_AND_MARGINS,
    &[ADVISORIES],
]);

/// The Python client's `timeseries.csv` (`decoy_bridge.flight`): one row per
/// answered state, `decoy feed`'s output columns from the bridge's outputs.
pub const CLIENT_TIMESERIES: CsvFile = CsvFile {
    id: "client_timeseries",
    file: "timeseries.csv",
    written_by: "the Python client (decoy_bridge.flight)",
    columns: &CLIENT_TIMESERIES_COLUMNS,
};

/// The three components of a NED vector quantity, named `<north>`, `<east>`,
/// `<down>`.
macro_rules! ned {
    ($q:ident, [$n:literal, $e:literal, $d:literal], $unit:literal, $what:literal) => {
        [
            Column::new(Quantity::$q(0), $n, $unit, concat!($what, ", north (NED)")),
            Column::new(Quantity::$q(1), $e, $unit, concat!($what, ", east (NED)")),
            Column::new(Quantity::$q(2), $d, $unit, concat!($what, ", down (NED)")),
        ]
    };
}

/// The three components of a body-frame (FRD) vector quantity.
macro_rules! body {
    ($q:ident, [$x:literal, $y:literal, $z:literal], $unit:literal, $what:literal) => {
        [
            Column::new(
                Quantity::$q(0),
                $x,
                $unit,
                concat!($what, " about the body x axis (FRD)"),
            ),
            Column::new(
                Quantity::$q(1),
                $y,
                $unit,
                concat!($what, " about the body y axis (FRD)"),
            ),
            Column::new(
                Quantity::$q(2),
                $z,
                $unit,
                concat!($what, " about the body z axis (FRD)"),
            ),
        ]
    };
}

/// A flight simulation's own quantity of the trajectory.
const fn flight_test(name: &'static str, unit: &'static str, description: &'static str) -> Column {
    Column::new(Quantity::FlightTest, name, unit, description)
}

const CLIENT_TRAJECTORY_COLUMNS: [Column; 32] = join(&[
    &[TIME.described("time of the state sent")],
    &ned!(
        PositionNed,
        ["north_m", "east_m", "down_m"],
        "m",
        "aircraft reference point"
    ),
    &ned!(
        VelocityNed,
        ["vn_mps", "ve_mps", "vd_mps"],
        "m/s",
        "velocity over the ground"
    ),
    &ned!(
        AccelerationNed,
        ["an_mps2", "ae_mps2", "ad_mps2"],
        "m/s²",
        "acceleration"
    ),
    &[
        Column::new(
            Quantity::Attitude(0),
            "qw",
            "",
            "attitude, Hamilton quaternion, body (FRD) to NED: scalar part",
        ),
        Column::new(Quantity::Attitude(1), "qx", "", "attitude quaternion: x"),
        Column::new(Quantity::Attitude(2), "qy", "", "attitude quaternion: y"),
        Column::new(Quantity::Attitude(3), "qz", "", "attitude quaternion: z"),
    ],
    &body!(
        BodyRate,
        ["p_radps", "q_radps", "r_radps"],
        "rad/s",
        "body rate"
    ),
    &body!(
        BodyAngularAcceleration,
        ["pdot_radps2", "qdot_radps2", "rdot_radps2"],
        "rad/s²",
        "body angular acceleration"
    ),
    &[
        flight_test("mach", "", "Mach number"),
        flight_test("altitude_m", "m", "altitude"),
        flight_test("airspeed_mps", "m/s", "true airspeed"),
        flight_test(
            "load_factor",
            "g",
            "load factor (JSBSim's `accelerations/Nz`: 1 in level flight)",
        ),
        flight_test("roll_deg", "deg", "roll (JSBSim's Euler angles)"),
        flight_test("pitch_deg", "deg", "pitch (JSBSim's Euler angles)"),
        flight_test("heading_deg", "deg", "heading (JSBSim's Euler angles)"),
        flight_test(
            "flight_path_deg",
            "deg",
            "flight-path angle, positive climbing",
        ),
        flight_test("alpha_deg", "deg", "angle of attack"),
        flight_test("throttle", "", "throttle command the loops set, normalised"),
        flight_test(
            "elevator_cmd",
            "",
            "elevator command the loops set, normalised",
        ),
        flight_test(
            "aileron_cmd",
            "",
            "aileron command the loops set, normalised",
        ),
    ],
]);

/// The Python client's `trajectory.csv` (`decoy_bridge.flight`): the state sent
/// each frame (as the solver takes it), then the flight simulation's own
/// quantities (the F-16 example's: JSBSim's).
pub const CLIENT_TRAJECTORY: CsvFile = CsvFile {
    id: "client_trajectory",
    file: "trajectory.csv",
    written_by: "the Python client (decoy_bridge.flight)",
    columns: &CLIENT_TRAJECTORY_COLUMNS,
};

/// A recorded flight, the input of a `recorded` scenario (docs/outputs.md,
/// "Recorded flights"): the aircraft's state at each sample.
pub const RECORDED_FLIGHT: CsvFile = CsvFile {
    id: "recorded_flight",
    file: "a recorded flight",
    written_by: "a flight recorder (read by decoy simulate's recorded scenarios; decoy-sim's example make_recorded_example writes scenarios/recorded-example.csv)",
    columns: &[
        TIME.described("time, strictly increasing (simulation time 0 is the first sample)"),
        Column::new(
            Quantity::PositionNed(0),
            "north_m",
            "m",
            "aircraft reference point, north (NED)",
        ),
        Column::new(
            Quantity::PositionNed(1),
            "east_m",
            "m",
            "aircraft reference point, east (NED)",
        ),
        Column::new(
            Quantity::PositionNed(2),
            "down_m",
            "m",
            "aircraft reference point, down (NED; altitude = -down, 0 to 20 000 m)",
        ),
        Column::new(
            Quantity::VelocityNed(0),
            "vn_mps",
            "m/s",
            "its velocity, north (NED)",
        ),
        Column::new(
            Quantity::VelocityNed(1),
            "ve_mps",
            "m/s",
            "its velocity, east (NED)",
        ),
        Column::new(
            Quantity::VelocityNed(2),
            "vd_mps",
            "m/s",
            "its velocity, down (NED)",
        ),
        Column::new(
            Quantity::Attitude(0),
            "qw",
            "",
            "attitude, Hamilton quaternion, body (FRD) to NED, unit length within 1e-3 (normalised): scalar part",
        ),
        Column::new(Quantity::Attitude(1), "qx", "", "attitude quaternion: x"),
        Column::new(Quantity::Attitude(2), "qy", "", "attitude quaternion: y"),
        Column::new(Quantity::Attitude(3), "qz", "", "attitude quaternion: z"),
        Column::new(
            Quantity::BodyRate(0),
            "p_radps",
            "rad/s",
            "body rate about the body x axis (FRD)",
        ),
        Column::new(
            Quantity::BodyRate(1),
            "q_radps",
            "rad/s",
            "body rate about the body y axis (FRD)",
        ),
        Column::new(
            Quantity::BodyRate(2),
            "r_radps",
            "rad/s",
            "body rate about the body z axis (FRD)",
        ),
    ],
};

/// Every CSV file the tools write (and the recorded flights they read).
pub const CSV_FILES: [CsvFile; 6] = [
    SIMULATE_TIMESERIES,
    SIMULATE_CABLE,
    HIL_TIMESERIES,
    CLIENT_TIMESERIES,
    CLIENT_TRAJECTORY,
    RECORDED_FLIGHT,
];

/// The names of `columns`, as an array of `N` (`N` their count: checked when
/// the constant is evaluated), for a header that must be a constant.
pub const fn column_names<const N: usize>(columns: &[Column]) -> [&'static str; N] {
    assert!(columns.len() == N, "column_names: not N columns");
    let mut out = [""; N];
    let mut i = 0;
    while i < N {
        out[i] = columns[i].name;
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::string::{String, ToString};
    use std::vec::Vec;

    use super::*;

    /// The headers the files had before this schema, byte for byte (the
    /// outputs' text must not change).
    #[test]
    fn the_headers_are_the_files_headers() {
        assert_eq!(
            SIMULATE_TIMESERIES.header().to_string(),
            "t_s,tension_connection_N,tension_tow_N,decoy_cg_behind_m,decoy_cg_lateral_m,decoy_cg_below_m,decoy_roll_deg,decoy_pitch_deg,decoy_yaw_deg,decoy_aoa_deg,cable_exhaust_clearance_m,cable_exhaust_closest_along_m,decoy_aircraft_clearance_m,aircraft_speed_mps,aircraft_altitude_m,posture_level,posture_margin_deg,collision_level,collision_margin_m,tension_level,tension_margin_N,exhaust_level,exhaust_margin_m,advisories,posture_violation_in_s,collision_violation_in_s,tension_violation_in_s,exhaust_violation_in_s"
        );
        assert_eq!(
            SIMULATE_CABLE.header().to_string(),
            "t_s,joint,along_m,behind_m,lateral_m,below_m,tension_N"
        );
        assert_eq!(
            HIL_TIMESERIES.header().to_string(),
            "t_s,seq,tension_connection_N,tension_tow_N,decoy_cg_behind_m,decoy_cg_lateral_m,decoy_cg_below_m,decoy_roll_deg,decoy_pitch_deg,decoy_yaw_deg,decoy_aoa_deg,cable_exhaust_clearance_m,decoy_aircraft_clearance_m,aircraft_speed_mps,aircraft_altitude_m,flags,rk4_steps,instructions,host_tension_connection_N,host_tension_tow_N,host_decoy_pitch_deg,host_decoy_aoa_deg,tension_connection_diff_N,tension_tow_diff_N,prediction_steps,management_instructions,posture_level,posture_margin_deg,collision_level,collision_margin_m,tension_level,tension_margin_N,exhaust_level,exhaust_margin_m,advisories,posture_violation_in_s,collision_violation_in_s,tension_violation_in_s,exhaust_violation_in_s,limit_pull_up_radps,limit_turn_radps,limit_acceleration_mps2,limit_floor_pull_up_radps,limit_floor_turn_radps,limit_floor_acceleration_mps2"
        );
        assert_eq!(
            CLIENT_TIMESERIES.header().to_string(),
            "t_s,seq,tension_connection_N,tension_tow_N,decoy_cg_behind_m,decoy_cg_lateral_m,decoy_cg_below_m,decoy_roll_deg,decoy_pitch_deg,decoy_yaw_deg,decoy_aoa_deg,cable_exhaust_clearance_m,decoy_aircraft_clearance_m,aircraft_speed_mps,aircraft_altitude_m,aircraft_load_factor,flags,rk4_steps,instructions,latency_us,posture_level,posture_margin_deg,collision_level,collision_margin_m,tension_level,tension_margin_N,exhaust_level,exhaust_margin_m,advisories"
        );
        assert_eq!(
            RECORDED_FLIGHT.header().to_string(),
            "t_s,north_m,east_m,down_m,vn_mps,ve_mps,vd_mps,qw,qx,qy,qz,p_radps,q_radps,r_radps"
        );
        assert_eq!(
            CLIENT_TRAJECTORY.header().to_string(),
            "t_s,north_m,east_m,down_m,vn_mps,ve_mps,vd_mps,an_mps2,ae_mps2,ad_mps2,qw,qx,qy,qz,p_radps,q_radps,r_radps,pdot_radps2,qdot_radps2,rdot_radps2,mach,altitude_m,airspeed_mps,load_factor,roll_deg,pitch_deg,heading_deg,flight_path_deg,alpha_deg,throttle,elevator_cmd,aileron_cmd"
        );
    }

    /// In every file each column's name is unique, ends in its unit where it
    /// has one, and each quantity appears once (but a flight test's own).
    #[test]
    fn names_and_quantities_are_unique_and_units_end_the_names() {
        for file in CSV_FILES {
            let names: Vec<&str> = file.names().collect();
            for (k, c) in file.columns.iter().enumerate() {
                assert!(
                    !c.name.is_empty() && !c.description.is_empty(),
                    "{}",
                    file.id
                );
                assert!(
                    !names[..k].contains(&c.name),
                    "{}: {} twice",
                    file.id,
                    c.name
                );
                if c.quantity != Quantity::FlightTest {
                    assert_eq!(
                        file.position(c.quantity),
                        Some(k),
                        "{}: {}",
                        file.id,
                        c.name
                    );
                }
                let suffix: String = match c.unit {
                    "" | "µs" | "g" => String::new(),
                    "m/s" => "_mps".into(),
                    "m/s²" => "_mps2".into(),
                    "rad/s" => "_radps".into(),
                    "rad/s²" => "_radps2".into(),
                    unit => std::format!("_{unit}"),
                };
                assert!(
                    c.name.ends_with(suffix.as_str()),
                    "{}: {} does not end in its unit {}",
                    file.id,
                    c.name,
                    c.unit
                );
            }
        }
    }

    /// Each requirement has its level, margin (in its file unit) and, where
    /// the file has the look-ahead's times, its time to violation.
    #[test]
    fn every_requirement_has_its_columns() {
        for file in [SIMULATE_TIMESERIES, HIL_TIMESERIES, CLIENT_TIMESERIES] {
            for r in Requirement::ALL {
                let margin = file.position(Quantity::Margin(r)).unwrap();
                assert_eq!(file.columns[margin].unit, r.file_unit());
                assert_eq!(
                    file.columns[margin].name,
                    std::format!("{}_margin_{}", r.name(), r.file_unit())
                );
                assert_eq!(file.position(Quantity::Level(r)), Some(margin - 1));
            }
        }
        for file in [SIMULATE_TIMESERIES, HIL_TIMESERIES] {
            for r in Requirement::ALL {
                assert!(file.position(Quantity::ViolationIn(r)).is_some());
            }
        }
    }
}
