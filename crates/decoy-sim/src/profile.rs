//! [`FlightProfile`]: the aircraft trajectory of a scenario, one of the paper's
//! prescribed manoeuvres or a recorded flight.

use solver_core::profiles::ManoeuvrePath;
use solver_core::{AircraftState, FlightPath, Real};

use crate::flyable::Flyable;
use crate::recorded::RecordedFlight;

/// The prescribed aircraft motion of a run.
#[derive(Clone, Debug, PartialEq)]
pub enum FlightProfile {
    /// One of `decoy_schema`'s manoeuvres, flown by solver-core's profile.
    Manoeuvre(ManoeuvrePath),
    /// A pull-up or turn built over a finite onset ([`crate::flyable`]).
    Flyable(Flyable),
    /// A recorded flight, interpolated.
    Recorded(RecordedFlight),
}

impl FlightProfile {
    /// When the manoeuvre starts, s: the acceleration, pull-up or turn start (0
    /// for steady flight and recorded flights). The decoy pitch oscillation
    /// amplitude of the summary is measured from then on.
    pub fn manoeuvre_start(&self) -> f64 {
        match self {
            FlightProfile::Manoeuvre(p) => p.manoeuvre_start(),
            FlightProfile::Flyable(p) => p.manoeuvre_start(),
            FlightProfile::Recorded(_) => 0.0,
        }
    }

    /// The times in (0, `t_end`), s, at which the path's acceleration or rotation
    /// rate jumps (or, built over an onset, its angular acceleration does),
    /// increasing: a manoeuvre's start and end (and its ramps'), a recorded flight's
    /// samples (its cubic Hermite is continuous in velocity, not in acceleration,
    /// at every sample). The run's steps end exactly at each ([`crate::steps`]).
    pub fn breakpoints(&self, t_end: f64) -> Vec<f64> {
        let mut times: Vec<f64> = match self {
            FlightProfile::Manoeuvre(p) => p.breakpoints().into_iter().flatten().collect(),
            FlightProfile::Flyable(p) => p.breakpoints(),
            FlightProfile::Recorded(r) => {
                let first = r.samples()[0].time;
                r.samples().iter().map(|s| s.time - first).collect()
            }
        };
        times.retain(|&t| t > 0.0 && t < t_end);
        times.sort_by(f64::total_cmp);
        times.dedup();
        times
    }

    /// The steady straight flight condition at t = 0 that the initial state is
    /// built for: the path's position, velocity and attitude at t = 0 with its
    /// acceleration and rotation set to zero.
    pub fn initial_condition(&self) -> AircraftState<f64> {
        let mut s = self.state_at(0.0);
        s.acceleration = nalgebra::Vector3::zeros();
        s.angular_rate = nalgebra::Vector3::zeros();
        s.angular_acceleration = nalgebra::Vector3::zeros();
        s
    }
}

impl FlightProfile {
    /// The aircraft state at `t`, s, in f64 (the trait gives any precision).
    pub fn state_at(&self, t: f64) -> AircraftState<f64> {
        FlightPath::<f64>::state_at(self, t)
    }
}

/// Computed in f64 and rounded to `T`.
impl<T: Real> FlightPath<T> for FlightProfile {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        match self {
            FlightProfile::Manoeuvre(p) => p.state_at(t),
            FlightProfile::Flyable(p) => FlightPath::<T>::state_at(p, t),
            FlightProfile::Recorded(p) => FlightPath::<T>::state_at(p, t),
        }
    }
}

impl From<ManoeuvrePath> for FlightProfile {
    fn from(path: ManoeuvrePath) -> Self {
        FlightProfile::Manoeuvre(path)
    }
}
