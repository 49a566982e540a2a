//! [`trace()`]: a run kept in memory, for the sweeps, the discretisation study
//! and the reproduction report.
//!
//! The same integration and measurements as [`crate::simulate`] (every step is
//! measured from RK4's first-stage evaluation), but nothing is written: the
//! samples, snapshots and statistics are returned, and a run that diverges is a
//! result ([`Trace::stopped`]), not an error, so that a caller can retry with a
//! shorter step. It can also start from a perturbed trim (the decoy pitched about
//! its towing point), which `decoy sweep tow-point` and `cg` use to watch the
//! decoy settle.

use decoy_config::SystemConfig;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use solver_core::{Model, Solver, State, trim};

use crate::capacity::with_capacity;
use crate::error::SimError;
use crate::format::round_time;
use crate::record::{Recorder, SAMPLE_INTERVAL_S, SNAPSHOT_INTERVAL_S, Sample, Snapshot, probe};
use crate::run::{integrate, straight_state};
use crate::scenario::RunPlan;
use crate::summary::StoppedAt;

/// The state a traced run starts from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Start {
    /// The trim of the flight condition at t = 0; no trim is [`SimError::NoTrim`].
    #[default]
    Trim,
    /// The cable trailing straight behind the connection point, the decoy along
    /// the flight direction (as `--initial straight`).
    Straight,
    /// The trim when one exists, else the straight state ([`Trace::from_trim`]
    /// tells which).
    TrimElseStraight,
}

/// How [`trace()`] runs and what it keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceOptions {
    /// The initial state.
    pub start: Start,
    /// Pitch the decoy nose-up by this angle (deg) about its towing point before
    /// starting, with no angular rate; the cable is left as it is.
    pub pitch_offset_deg: f64,
    /// Keep a sample every this many seconds (at least every step; the initial and
    /// final states always), s.
    pub sample_interval_s: f64,
    /// Keep a cable snapshot every this many seconds, s.
    pub snapshot_interval_s: f64,
}

impl Default for TraceOptions {
    /// From trim, unperturbed, the intervals of `timeseries.csv` and `cable.csv`.
    fn default() -> Self {
        TraceOptions {
            start: Start::Trim,
            pitch_offset_deg: 0.0,
            sample_interval_s: SAMPLE_INTERVAL_S,
            snapshot_interval_s: SNAPSHOT_INTERVAL_S,
        }
    }
}

/// A run kept in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// The plan that was run.
    pub plan: RunPlan,
    /// True when the run started from the trim (possibly pitched), false when from
    /// the straight state.
    pub from_trim: bool,
    /// Decoy pitch of the unperturbed initial state, deg.
    pub initial_pitch_deg: f64,
    /// The kept samples, in time order (initial and last good state included).
    pub samples: Vec<Sample>,
    /// The kept cable snapshots.
    pub snapshots: Vec<Snapshot>,
    /// Distance of each joint from the connection point along the cable, m.
    pub joint_along_m: Vec<f64>,
    /// Largest connection tension over every step, N.
    pub max_tension_connection_n: f64,
    /// When, s.
    pub t_at_max_tension_s: f64,
    /// Half the peak-to-peak decoy pitch from the manoeuvre start on, over every
    /// step, deg (as `summary.json`).
    pub pitch_oscillation_amplitude_deg: f64,
    /// Smallest cable clearance to the exhaust plume over every step, m.
    pub min_cable_clearance_to_exhaust_m: f64,
    /// Smallest decoy CG clearance to the aircraft's envelope over every step, m.
    pub min_decoy_clearance_to_aircraft_m: f64,
    /// Where and why the integration stopped early (the state diverged), if it did.
    pub stopped: Option<StoppedAt>,
}

impl Trace {
    /// The last kept sample (the last good state).
    pub fn last(&self) -> &Sample {
        // `integrate` always keeps the initial state, so there is one.
        &self.samples[self.samples.len() - 1]
    }
}

/// Runs `plan` on `config` in memory from the start in `options`; `progress` gets
/// the fraction of steps done now and then.
///
/// Errors: no trim ([`Start::Trim`]), an unusable configuration or initial state.
/// A divergence while stepping is not an error: [`Trace::stopped`] says when and
/// why, and the samples end at the last good state.
pub fn trace(
    config: &SystemConfig,
    plan: &RunPlan,
    options: &TraceOptions,
    progress: impl FnMut(f64),
) -> Result<Trace, SimError> {
    with_capacity!(plan.layout.count(), N => trace_with::<N>(config, plan, options, progress))
}

/// The decoy attitude `[w, x, y, z]` pitched nose-up by `pitch_deg` about its body
/// y axis (FRD: a positive rotation about y raises the nose).
pub fn pitched_attitude(attitude: [f64; 4], pitch_deg: f64) -> [f64; 4] {
    let [w, x, y, z] = attitude;
    let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
    let pitched = q * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), pitch_deg.to_radians());
    [pitched.w, pitched.i, pitched.j, pitched.k]
}

fn trace_with<const N: usize>(
    config: &SystemConfig,
    plan: &RunPlan,
    options: &TraceOptions,
    progress: impl FnMut(f64),
) -> Result<Trace, SimError> {
    let model: Model<f64, N> = config.model(plan.layout)?;
    let initial = plan.profile.initial_condition();
    let (mut state, from_trim): (State<f64, N>, bool) = match options.start {
        Start::Trim => (trim(&model, &initial).map_err(SimError::NoTrim)?, true),
        Start::Straight => (straight_state(&model, &initial), false),
        Start::TrimElseStraight => match trim(&model, &initial) {
            Ok(s) => (s, true),
            Err(_) => (straight_state(&model, &initial), false),
        },
    };
    let initial_pitch_deg = state.decoy_rotation().euler_angles().1.to_degrees();
    if options.pitch_offset_deg != 0.0 {
        state.decoy_attitude = pitched_attitude(state.decoy_attitude, options.pitch_offset_deg);
        state.decoy_rate = Vector3::zeros();
    }
    let probe = probe(config, &model, plan.lateral_sign);
    let joint_along_m = probe.joint_along.clone();
    let mut solver: Box<Solver<f64, N>> =
        Box::new(Solver::new(model, state).map_err(SimError::Initial)?);
    let mut recorder = Recorder::new(
        plan,
        probe,
        None,
        options.sample_interval_s,
        options.snapshot_interval_s,
    );
    let stopped = integrate(&mut solver, plan, &mut recorder, progress, &|| None)?;
    let statistics = &recorder.statistics;
    Ok(Trace {
        plan: plan.clone(),
        from_trim,
        initial_pitch_deg,
        max_tension_connection_n: statistics.max_tension,
        t_at_max_tension_s: round_time(statistics.t_at_max),
        pitch_oscillation_amplitude_deg: statistics.pitch_amplitude(),
        min_cable_clearance_to_exhaust_m: statistics.min_exhaust,
        min_decoy_clearance_to_aircraft_m: statistics.min_decoy,
        stopped: stopped.map(|stop| StoppedAt {
            t_s: round_time(recorder.last.t),
            reason: stop.reason,
        }),
        joint_along_m,
        samples: std::mem::take(&mut recorder.samples),
        snapshots: std::mem::take(&mut recorder.snapshots),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pitching_raises_the_nose_by_the_angle() {
        let level = [1.0, 0.0, 0.0, 0.0];
        let q = pitched_attitude(level, 5.0);
        let rotation = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
        let (roll, pitch, yaw) = rotation.euler_angles();
        assert!((pitch.to_degrees() - 5.0).abs() < 1e-12);
        assert!(roll.abs() < 1e-12 && yaw.abs() < 1e-12);
        // The nose (body x) points up: negative NED z.
        assert!((rotation * Vector3::x()).z < 0.0);
    }
}
