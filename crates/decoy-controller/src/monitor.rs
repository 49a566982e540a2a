//! Decoy management: one monitor per requirement of the paper (decoy posture
//! stable, no collision with the aircraft, cable tension within its allowable
//! value, cable out of the hot exhaust jet; the list is
//! [`decoy_schema::Requirement`], and every per-requirement value here is a
//! [`PerRequirement`]).
//!
//! Every monitor turns one measured state into a **margin** in its own unit
//! (negative: the requirement is violated) and a **level** against the thresholds
//! of `[management]`:
//!
//! | level | margin |
//! |---|---|
//! | normal | >= caution |
//! | caution | < caution |
//! | warning | < warning |
//! | violated | < 0 |
//!
//! A level rises as soon as the margin crosses a threshold and falls only once
//! the margin is `hysteresis` above it (no chatter on a margin that hovers at a
//! threshold). Each monitor keeps its worst margin and counts the times its level
//! rose to caution, warning and violated since the run started.
//!
//! The margins ([`Measures::margins`]):
//!
//! - **posture**, rad: the smaller of (a) the oscillation limit minus the decoy's
//!   pitch/yaw oscillation amplitude over a sliding window (half the range of the
//!   decoy's pitch and yaw relative to its own airflow, its angle of attack and
//!   sideslip, after removing the window's least-squares trend, so a slow change
//!   of trim is not an oscillation; relative to the airflow because the flight
//!   path a manoeuvre turns carries the decoy's attitude with it without any
//!   instability), or the amplitude the window's
//!   growth projects one half window ahead if that is larger (a diverging
//!   oscillation loses margin before it is large), and (b) the aero table's
//!   usable angle of attack (where its restoring moment stops growing,
//!   [`usable_angle_of_attack`]) minus the decoy's total angle of attack;
//! - **collision**, m: the smallest clearance of the decoy's CG and of the cable
//!   (joints and segment midpoints farther than `cable_exclusion` along it from
//!   the connection point, which is on the aircraft) to the aircraft's capsule,
//!   minus the required clearance;
//! - **tension**, N: two sides with their own thresholds, over-tension (the
//!   allowable tension minus the highest joint tension) and slack (the lowest
//!   joint tension minus the slack threshold: a cable going slack is the
//!   precursor of a snatch load); the margin is the side at the higher level
//!   (ties: the smaller relative to its caution threshold), violated when either
//!   is negative;
//! - **exhaust**, m: the cable's clearance to the plume minus the required one.
//!
//! The window is a fixed ring of samples ([`SampleRing`], no heap; not
//! `heapless::HistoryBuf`, whose write keeps a bounds check the optimiser cannot
//! remove: the frame path must have no reachable panic, firmware/README.md "No
//! panic in flight"). Generic over the solver's scalar; the same code runs on
//! the host and the target.

use core::marker::PhantomData;
use decoy_link::{Management, MonitorLevel, MonitorReport};
use decoy_schema::{PerRequirement, Requirement};

use solver_core::{AircraftState, Outputs, Real, Vec3};

use crate::geometry::{Geometry, cable_plume_clearance};

/// atan2 in `T` through libm (the same bits on every platform).
fn libm_atan2<T: Real>(y: T, x: T) -> T {
    if core::mem::size_of::<T>() == 4 {
        T::lit(f64::from(libm::atan2f(
            y.to_f64() as f32,
            x.to_f64() as f32,
        )))
    } else {
        T::lit(libm::atan2(y.to_f64(), x.to_f64()))
    }
}

/// Capacity of the posture window, samples (2 s; kept in f32 whatever the
/// solver's precision: 800 B, which the Cortex-M7's 64 KiB needs).
pub const POSTURE_WINDOW_CAPACITY: usize = 100;
/// Interval between the posture window's samples, s (one sample per frame at most).
pub const POSTURE_SAMPLE_S: f64 = 0.02;
/// The longest posture window, s.
pub const MAX_POSTURE_WINDOW_S: f64 = POSTURE_WINDOW_CAPACITY as f64 * POSTURE_SAMPLE_S;
/// Rounding allowance on the posture sampling interval, s.
const SAMPLE_TOLERANCE_S: f64 = 1e-6;
/// Half-window amplitude below which the growth is not computed, rad (numerical
/// noise of a settled decoy).
const GROWTH_FLOOR_RAD: f64 = 1e-3;

/// The caution and warning thresholds and the hysteresis of one monitor, in its
/// unit (configuration `[management.<requirement>]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thresholds {
    /// Margin below which the level is caution.
    pub caution: f64,
    /// Margin below which the level is warning (<= caution).
    pub warning: f64,
    /// How far above a threshold the margin must come back to lower the level.
    pub hysteresis: f64,
}

/// Everything `[management]` configures, plain f64 (see
/// `config/reference-system.toml` for the reference values and their reasons).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManagementParams {
    /// Each requirement's thresholds, in its unit ([`Requirement::unit`]; the
    /// tension's are those of its over-tension side).
    pub thresholds: PerRequirement<Thresholds>,
    /// Largest acceptable pitch/yaw oscillation amplitude, rad.
    pub posture_amplitude_limit: f64,
    /// Length of the posture window, s (at most [`MAX_POSTURE_WINDOW_S`]).
    pub posture_window_s: f64,
    /// Required clearance of the decoy and the cable to the aircraft's capsule, m.
    pub collision_min_clearance: f64,
    /// Cable length from the connection point not checked for collision, m.
    pub collision_cable_exclusion: f64,
    /// Tension below which the cable counts as slack, N.
    pub slack_tension: f64,
    /// Thresholds of the slack side of the tension margin, N.
    pub slack: Thresholds,
    /// Required clearance of the cable to the plume, m.
    pub exhaust_min_clearance: f64,
    /// Look-ahead horizon, s.
    pub horizon_s: f64,
    /// Look-ahead RK4 steps per frame (the slice of work each frame does).
    pub prediction_steps_per_frame: u32,
    /// Longest look-ahead RK4 step, s (shorter where the wave-speed limit asks).
    pub prediction_max_step_s: f64,
    /// Segments of the look-ahead's model (`lookahead::prediction_params`).
    pub prediction_segments: usize,
}

/// [`Thresholds`] in the solver's precision.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelThresholds<T: Real> {
    /// See [`Thresholds::caution`].
    pub caution: T,
    /// See [`Thresholds::warning`].
    pub warning: T,
    /// See [`Thresholds::hysteresis`].
    pub hysteresis: T,
}

impl<T: Real> LevelThresholds<T> {
    fn of(t: &Thresholds) -> Self {
        LevelThresholds {
            caution: T::lit(t.caution),
            warning: T::lit(t.warning),
            hysteresis: T::lit(t.hysteresis),
        }
    }

    /// The level of `margin` with no history.
    pub fn level_of(&self, margin: T) -> MonitorLevel {
        if margin < T::zero() {
            MonitorLevel::Violated
        } else if margin < self.warning {
            MonitorLevel::Warning
        } else if margin < self.caution {
            MonitorLevel::Caution
        } else {
            MonitorLevel::Normal
        }
    }

    /// The level of `margin` coming from `current`: up at once, down only by the
    /// levels the margin clears by the hysteresis.
    pub fn next_level(&self, current: MonitorLevel, margin: T) -> MonitorLevel {
        let raw = self.level_of(margin);
        if raw >= current {
            raw
        } else {
            self.level_of(margin - self.hysteresis).min(current)
        }
    }
}

/// The management configuration in the solver's precision, with what is derived
/// from the system (allowable tension, usable angle of attack, cable stations).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ManagementConfig<T: Real> {
    /// Each requirement's thresholds (the tension's: its over-tension side).
    pub thresholds: PerRequirement<LevelThresholds<T>>,
    /// Oscillation amplitude limit, rad.
    pub amplitude_limit: T,
    /// Posture window, samples of [`POSTURE_SAMPLE_S`] (2 to the capacity).
    pub window_samples: usize,
    /// Usable total angle of attack, rad.
    pub usable_aoa: T,
    /// Required clearance to the capsule, m.
    pub collision_min_clearance: T,
    /// Cable not checked for collision from the connection point, m.
    pub cable_exclusion: T,
    /// Allowable tension, N.
    pub allowable_tension: T,
    /// Slack threshold, N.
    pub slack_tension: T,
    /// Thresholds of the slack side of the tension margin.
    pub slack_thresholds: LevelThresholds<T>,
    /// Steady wind, NED, m/s (the decoy's airflow).
    pub wind: Vec3<T>,
    /// Required clearance to the plume, m.
    pub exhaust_min_clearance: T,
    /// Look-ahead horizon, s.
    pub horizon_s: f64,
    /// Look-ahead RK4 steps per frame.
    pub prediction_steps_per_frame: u32,
    /// Longest look-ahead step, s.
    pub prediction_max_step_s: f64,
    /// Segments of the look-ahead's model.
    pub prediction_segments: usize,
}

impl<T: Real> ManagementConfig<T> {
    /// Every threshold and limit zero, as a constant of all zero bits: the
    /// configuration of an unconfigured controller (never used before
    /// `Controller::configure` replaces it).
    pub const ZERO: Self = {
        let t = LevelThresholds {
            caution: T::ZERO,
            warning: T::ZERO,
            hysteresis: T::ZERO,
        };
        ManagementConfig {
            thresholds: PerRequirement::splat(t),
            amplitude_limit: T::ZERO,
            window_samples: 0,
            usable_aoa: T::ZERO,
            collision_min_clearance: T::ZERO,
            cable_exclusion: T::ZERO,
            allowable_tension: T::ZERO,
            slack_tension: T::ZERO,
            slack_thresholds: t,
            wind: Vec3::new(T::ZERO, T::ZERO, T::ZERO),
            exhaust_min_clearance: T::ZERO,
            horizon_s: 0.0,
            prediction_steps_per_frame: 0,
            prediction_max_step_s: 0.0,
            prediction_segments: 0,
        }
    };

    /// The older half window's amplitude from which its growth counts: a fifth
    /// of the oscillation limit.
    pub fn growth_floor(&self) -> T {
        self.amplitude_limit * T::lit(0.2)
    }

    /// From the configured values, the allowable tension (N) and the usable angle
    /// of attack (rad).
    pub fn new(p: &ManagementParams, allowable_tension: f64, usable_aoa: f64) -> Self {
        let samples = libm::round(p.posture_window_s / POSTURE_SAMPLE_S) as usize;
        ManagementConfig {
            thresholds: p.thresholds.map(|t| LevelThresholds::of(&t)),
            amplitude_limit: T::lit(p.posture_amplitude_limit),
            window_samples: samples.clamp(2, POSTURE_WINDOW_CAPACITY),
            usable_aoa: T::lit(usable_aoa),
            collision_min_clearance: T::lit(p.collision_min_clearance),
            cable_exclusion: T::lit(p.collision_cable_exclusion),
            allowable_tension: T::lit(allowable_tension),
            slack_tension: T::lit(p.slack_tension),
            slack_thresholds: LevelThresholds::of(&p.slack),
            wind: Vec3::zeros(),
            exhaust_min_clearance: T::lit(p.exhaust_min_clearance),
            horizon_s: p.horizon_s,
            prediction_steps_per_frame: p.prediction_steps_per_frame,
            prediction_max_step_s: p.prediction_max_step_s,
            prediction_segments: p.prediction_segments,
        }
    }
}

/// The usable total angle of attack of an aerodynamic table `[alpha_deg, cl, cd,
/// cm]`, rad: the angle where the pitching moment stops growing more restoring
/// (the first row after which cm no longer falls), beyond which the decoy has no
/// static stability left to recover; the table's last angle if it never stops.
pub fn usable_angle_of_attack(rows: &[[f64; 4]]) -> f64 {
    for pair in rows.windows(2) {
        if pair[1][3] >= pair[0][3] {
            return pair[0][0].to_radians();
        }
    }
    rows.last().map_or(0.0, |r| r[0].to_radians())
}

/// What the monitors need from one solved state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measures<T: Real> {
    /// Time, s.
    pub time: f64,
    /// Decoy pitch and yaw relative to its airflow (angle of attack and sideslip
    /// in the body's x-z and x-y planes), rad (0 without a decoy).
    pub pitch_yaw: [T; 2],
    /// Decoy total angle of attack, rad (0 without a decoy).
    pub aoa: T,
    /// Smallest clearance of the decoy and the checked cable to the capsule, m.
    pub aircraft_clearance: T,
    /// Highest joint tension, N.
    pub tension_max: T,
    /// Lowest joint tension, N.
    pub tension_min: T,
    /// Cable clearance to the plume, m.
    pub exhaust_clearance: T,
}

impl<T: Real> Measures<T> {
    /// Measures the outputs `out` with the aircraft at `aircraft` (distances
    /// along the cable from the joints' positions: the rods are rigid).
    pub fn of<const N: usize>(
        out: &Outputs<'_, T, N>,
        aircraft: &AircraftState<T>,
        geometry: &Geometry<T>,
        config: &ManagementConfig<T>,
    ) -> Self {
        let n = out.segment_count();
        let (exhaust_clearance, _) = cable_plume_clearance(
            &geometry.plume,
            aircraft,
            (0..=n).map(|j| out.joint_position(j)),
        );
        let mut tension_max = out.tension(0);
        let mut tension_min = tension_max;
        // NED to body, formed once for every point.
        let to_body_matrix = aircraft
            .rotation()
            .to_rotation_matrix()
            .into_inner()
            .transpose();
        // A point farther from the capsule's centre than the best clearance so
        // far plus the capsule's half length and radius cannot be nearer: it is
        // skipped (the result is the same as checking every point).
        let e = &geometry.envelope;
        let centre = (e.fore + e.aft) * T::lit(0.5);
        let reach = (e.aft - e.fore).norm() * T::lit(0.5) + e.radius;
        let envelope = |p: &Vec3<T>, best: T| {
            let b = to_body_matrix * (p - aircraft.position);
            let limit = best + reach;
            if (b - centre).norm_squared() > limit * limit * T::lit(1.001) {
                best
            } else {
                best.min(e.clearance(&b))
            }
        };
        // Far beyond any aircraft: what is reported when nothing is checked.
        let mut clearance = T::lit(1e6);
        let half = T::lit(0.5);
        let mut along = T::zero();
        let mut previous = out.joint_position(0);
        for j in 1..=n {
            let t = out.tension(j);
            tension_max = tension_max.max(t);
            tension_min = tension_min.min(t);
            let p = out.joint_position(j);
            let l = (p - previous).norm();
            if along + l * half >= config.cable_exclusion {
                let mid = (previous + p) * half;
                clearance = envelope(&mid, clearance);
            }
            along += l;
            if along >= config.cable_exclusion {
                clearance = envelope(&p, clearance);
            }
            previous = p;
        }
        let (pitch_yaw, aoa) = match out.decoy() {
            Some(d) => {
                clearance = envelope(&d.cg_position, clearance);
                // The air's velocity relative to the decoy, body axes: the
                // body's pitch and yaw relative to its airflow.
                let v = d
                    .attitude
                    .inverse_transform_vector(&(d.cg_velocity - config.wind));
                let pitch = libm_atan2(v.z, v.x);
                let yaw = libm_atan2(v.y, v.x);
                ([pitch, yaw], d.angle_of_attack)
            }
            None => ([T::zero(); 2], T::zero()),
        };
        Measures {
            time: out.time(),
            pitch_yaw,
            aoa,
            aircraft_clearance: clearance,
            tension_max,
            tension_min,
            exhaust_clearance,
        }
    }

    /// True when every measure and margin is finite (and within f32's range):
    /// an accepted frame never carries anything else.
    pub fn is_finite(&self, config: &ManagementConfig<T>) -> bool {
        self.instant_margins(config)
            .into_array()
            .iter()
            .chain(&self.pitch_yaw)
            .all(|m| m.finite() && m.abs() < T::lit(1e30))
    }

    /// The tension margin, N, and the thresholds of its side (over-tension or
    /// slack, the one at the higher level; ties: the smaller margin relative to
    /// its caution threshold).
    pub fn tension_margin(&self, config: &ManagementConfig<T>) -> (T, LevelThresholds<T>) {
        tension_margin_of([self.tension_min, self.tension_max], config)
    }

    /// The margins of this state alone, each in its requirement's unit: the
    /// collision, tension and exhaust margins (m, N, m) and the angle-of-attack
    /// part of the posture margin (rad; the oscillation's part needs the window).
    pub fn instant_margins(&self, config: &ManagementConfig<T>) -> PerRequirement<T> {
        let (tension, _) = self.tension_margin(config);
        PerRequirement::from_fn(|requirement| match requirement {
            Requirement::Posture => config.usable_aoa - self.aoa.abs(),
            Requirement::Collision => self.aircraft_clearance - config.collision_min_clearance,
            Requirement::Tension => tension,
            Requirement::Exhaust => self.exhaust_clearance - config.exhaust_min_clearance,
        })
    }
}

/// The tension margin, N, of the lowest and highest joint `tensions` (N), and
/// the thresholds of its side (as [`Measures::tension_margin`]).
pub fn tension_margin_of<T: Real>(
    tensions: [T; 2],
    config: &ManagementConfig<T>,
) -> (T, LevelThresholds<T>) {
    let over = (
        config.allowable_tension - tensions[1],
        config.thresholds.tension,
    );
    let slack = (tensions[0] - config.slack_tension, config.slack_thresholds);
    let (lo, ls) = (over.1.level_of(over.0), slack.1.level_of(slack.0));
    let relative = |(m, t): (T, LevelThresholds<T>)| {
        if t.caution > T::zero() {
            m / t.caution
        } else {
            m
        }
    };
    if ls > lo || (ls == lo && relative(slack) < relative(over)) {
        slack
    } else {
        over
    }
}

/// One monitor's level, margins and counts.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Monitor<T: Real> {
    /// The level now.
    pub level: MonitorLevel,
    /// The margin now.
    pub margin: T,
    /// The smallest margin since the reset (None before the first).
    pub worst: Option<T>,
    /// Rises to caution or worse.
    pub cautions: u32,
    /// Rises to warning or worse.
    pub warnings: u32,
    /// Rises to violated.
    pub violations: u32,
}

impl<T: Real> Monitor<T> {
    /// A monitor of a new run (the `Default`).
    pub const NEW: Self = Monitor {
        level: MonitorLevel::Normal,
        margin: T::ZERO,
        worst: None,
        cautions: 0,
        warnings: 0,
        violations: 0,
    };

    /// Takes the margin of a new state.
    pub fn update(&mut self, margin: T, thresholds: &LevelThresholds<T>) {
        let old = self.level;
        let level = thresholds.next_level(old, margin);
        let rose = |to: MonitorLevel| old < to && level >= to;
        if rose(MonitorLevel::Caution) {
            self.cautions = self.cautions.wrapping_add(1);
        }
        if rose(MonitorLevel::Warning) {
            self.warnings = self.warnings.wrapping_add(1);
        }
        if rose(MonitorLevel::Violated) {
            self.violations = self.violations.wrapping_add(1);
        }
        self.level = level;
        self.margin = margin;
        self.worst = Some(match self.worst {
            Some(w) if w <= margin => w,
            _ => margin,
        });
    }

    /// The report of this monitor (no prediction yet: predicted = now, -1 s).
    pub fn report(&self) -> MonitorReport {
        let narrow = |v: T| v.to_f64() as f32;
        MonitorReport {
            level: self.level,
            margin: narrow(self.margin),
            worst_margin: narrow(self.worst.unwrap_or(self.margin)),
            cautions: self.cautions,
            warnings: self.warnings,
            violations: self.violations,
            predicted_worst_margin: narrow(self.margin),
            time_to_violation_s: -1.0,
        }
    }
}

/// The last [`POSTURE_WINDOW_CAPACITY`] samples, the oldest overwritten. Every
/// index is reduced below the capacity where it is formed, so no access can
/// panic (nor keep a bounds check).
#[derive(Clone, Copy, Debug)]
struct SampleRing {
    samples: [[f32; 2]; POSTURE_WINDOW_CAPACITY],
    /// Where the next sample goes (below the capacity).
    next: usize,
    /// Samples held (at most the capacity).
    len: usize,
}

impl SampleRing {
    const EMPTY: Self = SampleRing {
        samples: [[0.0; 2]; POSTURE_WINDOW_CAPACITY],
        next: 0,
        len: 0,
    };

    fn len(&self) -> usize {
        self.len.min(POSTURE_WINDOW_CAPACITY)
    }

    fn clear(&mut self) {
        self.next = 0;
        self.len = 0;
    }

    fn write(&mut self, sample: [f32; 2]) {
        let at = self.next % POSTURE_WINDOW_CAPACITY;
        self.samples[at] = sample;
        self.next = (at + 1) % POSTURE_WINDOW_CAPACITY;
        self.len = (self.len + 1).min(POSTURE_WINDOW_CAPACITY);
    }

    /// The samples, oldest first.
    fn oldest_ordered(&self) -> impl Iterator<Item = [f32; 2]> + '_ {
        let len = self.len();
        let start = (self.next % POSTURE_WINDOW_CAPACITY + POSTURE_WINDOW_CAPACITY - len)
            % POSTURE_WINDOW_CAPACITY;
        (0..len).map(move |k| {
            let at = start + k;
            let at = if at >= POSTURE_WINDOW_CAPACITY {
                at - POSTURE_WINDOW_CAPACITY
            } else {
                at
            };
            self.samples[at.min(POSTURE_WINDOW_CAPACITY - 1)]
        })
    }
}

/// The posture window: relative pitch and yaw sampled every [`POSTURE_SAMPLE_S`].
#[derive(Clone, Debug)]
pub struct PostureWindow<T: Real> {
    samples: SampleRing,
    last_time: Option<f64>,
    precision: PhantomData<T>,
}

impl<T: Real> Default for PostureWindow<T> {
    fn default() -> Self {
        PostureWindow {
            samples: SampleRing::EMPTY,
            last_time: None,
            precision: PhantomData,
        }
    }
}

impl<T: Real> PartialEq for PostureWindow<T> {
    fn eq(&self, other: &Self) -> bool {
        self.last_time == other.last_time
            && self.samples.len() == other.samples.len()
            && self
                .samples
                .oldest_ordered()
                .eq(other.samples.oldest_ordered())
    }
}

/// The posture window's amplitude, its growth and the amplitude it projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Oscillation<T: Real> {
    /// Half the detrended range over the window, the larger of pitch and yaw, rad.
    pub amplitude: T,
    /// Recent half's amplitude over the older half's (1 when not measurable).
    pub growth: T,
    /// The amplitude one half window ahead at that growth, rad.
    pub projected: T,
}

impl<T: Real> PostureWindow<T> {
    /// Empties the window.
    pub fn clear(&mut self) {
        self.samples.clear();
        self.last_time = None;
    }

    /// Adds a sample at `time` if [`POSTURE_SAMPLE_S`] has passed since the last.
    pub fn push(&mut self, time: f64, pitch_yaw: [T; 2]) {
        if let Some(last) = self.last_time
            && time - last < POSTURE_SAMPLE_S - SAMPLE_TOLERANCE_S
        {
            return;
        }
        // Narrowed to f32 (exact for an f32 solver): radians to 1e-7 relative.
        self.samples.write(pitch_yaw.map(|v| v.to_f64() as f32));
        self.last_time = Some(time);
    }

    /// The oscillation over the last `window` samples; the growth only where
    /// the older half's amplitude is at least `floor` (rad): the onset of a
    /// forced transient (from nothing to something) is not a divergence.
    pub fn oscillation(&self, window: usize, floor: T) -> Oscillation<T> {
        let floor = floor.max(T::lit(GROWTH_FLOOR_RAD));
        let len = self.samples.len();
        let count = window.min(len);
        let zero = T::zero();
        if count < 4 {
            return Oscillation {
                amplitude: zero,
                growth: T::one(),
                projected: zero,
            };
        }
        let skip = len - count;
        let mut amplitude = zero;
        let mut growth = T::one();
        let mut projected = zero;
        for axis in 0..2 {
            // Least-squares line through (k, v_k), k = 0..count.
            let values = || {
                self.samples
                    .oldest_ordered()
                    .skip(skip)
                    .map(move |s| T::lit(f64::from(s[axis])))
            };
            let n = T::lit(count as f64);
            let k_mean = T::lit((count - 1) as f64 * 0.5);
            let mut v_mean = zero;
            for v in values() {
                v_mean += v;
            }
            v_mean /= n;
            let (mut sxy, mut sxx) = (zero, zero);
            for (k, v) in values().enumerate() {
                let dk = T::lit(k as f64) - k_mean;
                sxy += dk * (v - v_mean);
                sxx += dk * dk;
            }
            let slope = sxy / sxx;
            let half = count / 2;
            let mut range = [[T::lit(f64::INFINITY), T::lit(f64::NEG_INFINITY)]; 2];
            for (k, v) in values().enumerate() {
                let r = v - v_mean - slope * (T::lit(k as f64) - k_mean);
                let part = &mut range[usize::from(k >= half)];
                part[0] = part[0].min(r);
                part[1] = part[1].max(r);
            }
            let older = (range[0][1] - range[0][0]) * T::lit(0.5);
            let recent = (range[1][1] - range[1][0]) * T::lit(0.5);
            let whole = (range[0][1].max(range[1][1]) - range[0][0].min(range[1][0])) * T::lit(0.5);
            let g = if older > floor {
                recent / older
            } else {
                T::one()
            };
            amplitude = amplitude.max(whole);
            projected = projected.max(recent * g);
            growth = growth.max(g);
        }
        Oscillation {
            amplitude,
            growth,
            projected,
        }
    }
}

/// The monitors, one per requirement, and the posture window.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Monitors<T: Real> {
    /// One monitor per requirement.
    pub monitors: PerRequirement<Monitor<T>>,
    window: PostureWindow<T>,
}

impl<T: Real> Monitors<T> {
    /// The monitors of a new run (the `Default`), as a constant of all zero bits.
    pub const NEW: Self = {
        let m = Monitor::NEW;
        Monitors {
            monitors: PerRequirement::splat(m),
            window: PostureWindow {
                samples: SampleRing::EMPTY,
                last_time: None,
                precision: PhantomData,
            },
        }
    };

    /// Back to the state of a new run (in place: no monitors-sized temporary
    /// on the stack).
    pub fn reset(&mut self) {
        for (_, m) in self.monitors.iter_mut() {
            *m = Monitor::NEW;
        }
        self.window.clear();
    }

    /// Takes one accepted state's measures; returns the margins.
    pub fn update(
        &mut self,
        measures: &Measures<T>,
        config: &ManagementConfig<T>,
    ) -> PerRequirement<T> {
        self.window.push(measures.time, measures.pitch_yaw);
        let oscillation = self
            .window
            .oscillation(config.window_samples, config.growth_floor());
        let mut margins = measures.instant_margins(config);
        margins.posture = margins
            .posture
            .min(config.amplitude_limit - oscillation.amplitude.max(oscillation.projected));
        let mut thresholds = config.thresholds;
        thresholds.tension = measures.tension_margin(config).1;
        for (requirement, monitor) in self.monitors.iter_mut() {
            monitor.update(margins[requirement], &thresholds[requirement]);
        }
        margins
    }

    /// The posture window's oscillation now.
    pub fn oscillation(&self, config: &ManagementConfig<T>) -> Oscillation<T> {
        self.window
            .oscillation(config.window_samples, config.growth_floor())
    }

    /// The report of the monitors (no prediction filled in).
    pub fn report(&self) -> Management {
        Management {
            reports: self.monitors.map(|m| m.report()),
            advisories: 0,
            prediction_from_s: -1.0,
            prediction_horizon_s: 0.0,
            limits: decoy_link::Limits::UNKNOWN,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thresholds() -> LevelThresholds<f64> {
        LevelThresholds {
            caution: 2.0,
            warning: 1.0,
            hysteresis: 0.25,
        }
    }

    #[test]
    fn levels_rise_at_once_and_fall_with_hysteresis() {
        let t = thresholds();
        let mut m = Monitor::<f64>::default();
        let mut levels = Vec::new();
        for margin in [3.0, 1.9, 0.9, -0.1, 0.1, 0.2, 1.1, 1.2, 1.3, 2.1, 2.3, 0.5] {
            m.update(margin, &t);
            levels.push(m.level.index());
        }
        assert_eq!(levels, [0, 1, 2, 3, 3, 3, 2, 2, 1, 1, 0, 2]);
        assert_eq!((m.cautions, m.warnings, m.violations), (2, 2, 1));
        assert_eq!(m.worst, Some(-0.1));
    }

    #[test]
    fn a_margin_hovering_at_a_threshold_does_not_chatter() {
        let t = thresholds();
        let mut m = Monitor::<f64>::default();
        for k in 0..100 {
            m.update(1.0 + 0.1 * libm::sin(k as f64), &t);
        }
        assert_eq!(m.warnings, 1);
        assert_eq!(m.cautions, 1);
    }

    #[test]
    fn the_usable_angle_is_where_the_restoring_moment_stops_growing() {
        let rows = [
            [0.0, 0.0, 0.4, 0.0],
            [10.0, 1.0, 0.5, -0.4],
            [20.0, 2.0, 0.6, -0.8],
            [30.0, 2.5, 0.9, -0.7],
            [180.0, 0.0, 0.4, 0.0],
        ];
        assert!((usable_angle_of_attack(&rows) - 20f64.to_radians()).abs() < 1e-15);
    }

    fn oscillation_of(f: impl Fn(f64) -> f64) -> Oscillation<f64> {
        let mut w = PostureWindow::<f64>::default();
        for k in 0..200 {
            let t = k as f64 * 0.01;
            w.push(t, [f(t), 0.0]);
        }
        w.oscillation(100, 1e-3)
    }

    #[test]
    fn a_trend_is_not_an_oscillation_and_growth_is_seen() {
        // A ramp: no oscillation (to the f32 samples' rounding, 1e-7 relative).
        let ramp = oscillation_of(|t| 0.05 * t);
        assert!(ramp.amplitude < 1e-8, "{ramp:?}");
        // A steady sine of 0.02 rad at 2 Hz: amplitude 0.02 (the least-squares
        // line of a sine over whole periods has a slope, so the detrended half
        // range reads up to 15 % more), no growth.
        let steady = oscillation_of(|t| 0.02 * libm::sin(4.0 * core::f64::consts::PI * t));
        assert!(
            steady.amplitude >= 0.0195 && steady.amplitude < 0.024,
            "{steady:?}"
        );
        assert!((steady.growth - 1.0).abs() < 0.1, "{steady:?}");
        // Growing e^t: the recent half larger, and the projection larger still.
        let growing =
            oscillation_of(|t| 0.01 * libm::exp(t) * libm::sin(4.0 * core::f64::consts::PI * t));
        assert!(growing.growth > 2.0, "{growing:?}");
        assert!(growing.projected > growing.amplitude, "{growing:?}");
    }

    #[test]
    fn samples_are_taken_at_most_every_sample_interval() {
        let mut w = PostureWindow::<f32>::default();
        for k in 0..100 {
            w.push(k as f64 * 0.01, [0.0, 0.0]);
        }
        assert_eq!(w.samples.len(), 50);
    }
}
