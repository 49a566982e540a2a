//! [`trim_point`]: the trim (steady equilibrium) of level flight at one flight
//! condition, with its cable, as `decoy trim` and the steady sweeps report it.

use decoy_config::SystemConfig;
use serde::Serialize;
use solver_core::{AircraftState, Model, SegmentLayout, SolveError, Solver, Uniform, trim};

use crate::capacity::with_capacity;
use crate::error::SimError;
use crate::geometry::FlightPathFrame;
use crate::scenario::{check_altitude, check_grading, check_mach, check_segments};

/// One joint of a trimmed cable: distance along the cable from the connection
/// point, behind and below the aircraft reference point (flight-path frame), m,
/// and the tension there, N.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CablePoint {
    /// Distance along the cable from the connection point, m.
    pub along_m: f64,
    /// Behind the aircraft reference point, m.
    pub behind_m: f64,
    /// Below the flight path, m.
    pub below_m: f64,
    /// Tension, N.
    #[serde(rename = "tension_N")]
    pub tension_n: f64,
}

/// The trim of steady level flight at one flight condition.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrimPoint {
    /// Mach number.
    pub mach: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// True airspeed, m/s.
    pub speed_mps: f64,
    /// Tension at the connection point (joint 0), N.
    #[serde(rename = "tension_connection_N")]
    pub tension_connection_n: f64,
    /// Tension at the towing point (joint N), N.
    #[serde(rename = "tension_tow_N")]
    pub tension_tow_n: f64,
    /// Largest tension along the cable, N.
    #[serde(rename = "tension_max_N")]
    pub tension_max_n: f64,
    /// Decoy pitch, deg, positive nose-up.
    pub decoy_pitch_deg: f64,
    /// Decoy total angle of attack, deg.
    pub decoy_aoa_deg: f64,
    /// Decoy CG behind the aircraft reference point, m.
    pub decoy_cg_behind_m: f64,
    /// Decoy CG below the flight path (the decoy's depth), m.
    pub decoy_cg_below_m: f64,
    /// Smallest distance from the cable (every joint and segment midpoint) to the
    /// exhaust plume's surface, m (negative inside), as `decoy simulate` measures it.
    pub cable_plume_clearance_m: f64,
    /// Decoy CG behind the cable's connection point along the flight path, m.
    #[serde(skip)]
    pub decoy_cg_behind_connection_m: f64,
    /// Decoy CG below the cable's connection point, m.
    #[serde(skip)]
    pub decoy_cg_below_connection_m: f64,
    /// The cable, joint 0 (connection point) to joint N (towing point).
    #[serde(skip)]
    pub cable: Vec<CablePoint>,
}

/// What `decoy trim` asks for: the flight condition and the cable's layout
/// (`None`: the configuration's `solver.segments_host`, uniform).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrimRequest {
    /// Aircraft altitude, m (`--altitude`).
    pub altitude: f64,
    /// Aircraft Mach number (`--mach`).
    pub mach: f64,
    /// Cable segments (`--segments`).
    pub segments: Option<usize>,
    /// Segment length ratio, short at the decoy (`--grading`; 1 = uniform).
    pub grading: Option<f64>,
}

/// `decoy trim`'s result: the request's layout and its trim point.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelTrim {
    /// The checked layout.
    pub layout: SegmentLayout<f64>,
    /// The trim and its cable.
    pub point: TrimPoint,
}

/// `decoy trim --json`: the trim's decoy pitch, tensions and decoy CG (see
/// `docs/outputs.md`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrimReport {
    /// Decoy pitch, degrees, positive nose-up.
    pub decoy_pitch_deg: f64,
    /// Tension at the connection point (joint 0), N.
    #[serde(rename = "tension_connection_N")]
    pub tension_connection_n: f64,
    /// Tension at the towing point (joint N), N.
    #[serde(rename = "tension_tow_N")]
    pub tension_tow_n: f64,
    /// Decoy CG behind the aircraft reference point along the flight path, m (as
    /// `decoy_cg_behind_m` in every output).
    pub decoy_cg_behind_m: f64,
    /// Decoy CG below the flight path, from the aircraft reference point, m.
    pub decoy_cg_below_m: f64,
    /// Decoy CG behind the cable's connection point along the flight path, m.
    pub decoy_cg_behind_connection_m: f64,
    /// Decoy CG below the cable's connection point, m.
    pub decoy_cg_below_connection_m: f64,
    /// Tension at joints 0 (connection) to N (towing point), N.
    #[serde(rename = "tension_profile_N")]
    pub tension_profile_n: Vec<f64>,
}

impl LevelTrim {
    /// The report `decoy trim --json` prints.
    pub fn report(&self) -> TrimReport {
        let p = &self.point;
        TrimReport {
            decoy_pitch_deg: p.decoy_pitch_deg,
            tension_connection_n: p.tension_connection_n,
            tension_tow_n: p.tension_tow_n,
            decoy_cg_behind_m: p.decoy_cg_behind_m,
            decoy_cg_below_m: p.decoy_cg_below_m,
            decoy_cg_behind_connection_m: p.decoy_cg_behind_connection_m,
            decoy_cg_below_connection_m: p.decoy_cg_below_connection_m,
            tension_profile_n: p.cable.iter().map(|c| c.tension_n).collect(),
        }
    }
}

/// The trim of steady level flight `decoy trim` reports: checks the request
/// (errors name the flag: `--altitude`, `--mach`, `--segments`, `--grading`),
/// then [`trim_point`]. A trim with a non-finite tension is
/// [`SimError::Initial`], naming the first such joint.
pub fn level_trim(config: &SystemConfig, request: &TrimRequest) -> Result<LevelTrim, SimError> {
    let cli = |field: &str, message: String| SimError::invalid("command line", field, message);
    check_altitude(&cli, "--altitude", request.altitude)?;
    check_mach(&cli, "--mach", request.mach)?;
    let layout = host_layout(config, request.segments, request.grading)?;
    let point = trim_point(config, layout, request.altitude, request.mach)?;
    if let Some(joint) = point.cable.iter().position(|c| !c.tension_n.is_finite()) {
        return Err(SimError::Initial(SolveError::NonFinite { joint }));
    }
    Ok(LevelTrim { layout, point })
}

/// The layout of `segments` (`--segments`; `None`: the configuration's
/// `solver.segments_host`) graded by `grading` (`--grading`; `None` or 1:
/// uniform), checked: an error names the flag, or the configuration file and
/// its key when the value came from there.
pub fn host_layout(
    config: &SystemConfig,
    segments: Option<usize>,
    grading: Option<f64>,
) -> Result<SegmentLayout<f64>, SimError> {
    let cli = |field: &str, message: String| SimError::invalid("command line", field, message);
    let count = match segments {
        Some(count) => {
            check_segments(&cli, "--segments", count)?;
            count
        }
        None => {
            let count = config.solver.segments_host;
            let from_config =
                |field: &str, message: String| SimError::invalid(&config.source, field, message);
            check_segments(&from_config, "solver.segments_host", count)?;
            count
        }
    };
    Ok(match grading {
        None => SegmentLayout::Uniform { count },
        Some(ratio) => {
            check_grading(&cli, "--grading", ratio)?;
            if ratio == 1.0 {
                SegmentLayout::Uniform { count }
            } else {
                SegmentLayout::Graded { count, ratio }
            }
        }
    })
}

/// The trim of steady level flight at `altitude` m and `mach` with `layout`, and
/// its cable. Errors: no trim ([`SimError::NoTrim`]), an unusable configuration.
pub fn trim_point(
    config: &SystemConfig,
    layout: SegmentLayout<f64>,
    altitude: f64,
    mach: f64,
) -> Result<TrimPoint, SimError> {
    with_capacity!(layout.count(), N => trim_point_with::<N>(config, layout, altitude, mach))
}

fn trim_point_with<const N: usize>(
    config: &SystemConfig,
    layout: SegmentLayout<f64>,
    altitude: f64,
    mach: f64,
) -> Result<TrimPoint, SimError> {
    let model: Model<f64, N> = config.model(layout)?;
    let n = model.segment_count();
    let speed = config.mach_to_speed(altitude, mach)?;
    let aircraft = AircraftState::level(altitude, speed);
    let state = trim(&model, &aircraft).map_err(SimError::NoTrim)?;
    let mut along = vec![0.0];
    for l in model.lengths() {
        along.push(along[along.len() - 1] + l);
    }
    let mut solver: Box<Solver<f64, N>> =
        Box::new(Solver::new(model, state).map_err(SimError::Initial)?);
    let path = Uniform { initial: aircraft };
    let out = solver.outputs(&path).map_err(SimError::Initial)?;
    let frame = FlightPathFrame::of(&aircraft);
    let relative = |p: &nalgebra::Vector3<f64>| frame.components(&(p - aircraft.position));
    let cable: Vec<CablePoint> = (0..=n)
        .map(|j| {
            let c = relative(&out.joint_position(j));
            CablePoint {
                along_m: along[j],
                behind_m: -c.x,
                below_m: c.z,
                tension_n: out.tension(j),
            }
        })
        .collect();
    let plume = crate::geometry::plume_from_config::<f64>(&config.aircraft);
    let (cable_plume_clearance_m, _) = crate::geometry::cable_plume_clearance(
        &plume,
        &aircraft,
        (0..=n).map(|j| out.joint_position(j)),
    );
    let connection = out.joint_position(0);
    let (pitch, aoa, cg, from_connection) = match out.decoy() {
        Some(d) => (
            d.euler.1.to_degrees(),
            d.angle_of_attack.to_degrees(),
            relative(&d.cg_position),
            frame.components(&(d.cg_position - connection)),
        ),
        None => {
            let nan = nalgebra::Vector3::repeat(f64::NAN);
            (f64::NAN, f64::NAN, nan, nan)
        }
    };
    Ok(TrimPoint {
        mach,
        altitude_m: altitude,
        speed_mps: speed,
        tension_connection_n: out.connection_tension(),
        tension_tow_n: out.tow_tension(),
        tension_max_n: cable
            .iter()
            .map(|c| c.tension_n)
            .fold(f64::NEG_INFINITY, f64::max),
        decoy_pitch_deg: pitch,
        decoy_aoa_deg: aoa,
        decoy_cg_behind_m: -cg.x,
        decoy_cg_below_m: cg.z,
        cable_plume_clearance_m,
        decoy_cg_behind_connection_m: -from_connection.x,
        decoy_cg_below_connection_m: from_connection.z,
        cable,
    })
}
