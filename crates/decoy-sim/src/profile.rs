//! [`FlightProfile`]: the aircraft trajectory of a scenario, one of the paper's
//! prescribed manoeuvres or a recorded flight.

use solver_core::profiles::{LevelAcceleration, LevelTurn, PullUp};
use solver_core::{AircraftState, FlightPath, Real};

use crate::recorded::RecordedFlight;

/// The prescribed aircraft motion of a run.
#[derive(Clone, Debug, PartialEq)]
pub enum FlightProfile {
    /// Steady level flight, or a level acceleration between two speeds.
    Level(LevelAcceleration),
    /// Level flight, then the flight path rotating up at a constant rate, then a climb.
    PullUp(PullUp),
    /// Level flight, then a level coordinated turn.
    Turn(LevelTurn),
    /// A recorded flight, interpolated.
    Recorded(RecordedFlight),
}

impl FlightProfile {
    /// When the manoeuvre starts, s: the acceleration, pull-up or turn start (0
    /// for steady flight and recorded flights). The decoy pitch oscillation
    /// amplitude of the summary is measured from then on.
    pub fn manoeuvre_start(&self) -> f64 {
        match self {
            FlightProfile::Level(p) => {
                if p.final_speed == p.initial_speed || p.acceleration == 0.0 {
                    0.0
                } else {
                    p.start
                }
            }
            FlightProfile::PullUp(p) => p.start,
            FlightProfile::Turn(p) => p.start,
            FlightProfile::Recorded(_) => 0.0,
        }
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
        match self {
            FlightProfile::Level(p) => p.state_at(t),
            FlightProfile::PullUp(p) => p.state_at(t),
            FlightProfile::Turn(p) => p.state_at(t),
            FlightProfile::Recorded(p) => p.state_at(t),
        }
    }
}

/// Computed in f64 and rounded to `T`.
impl<T: Real> FlightPath<T> for FlightProfile {
    fn state_at(&self, t: f64) -> AircraftState<T> {
        match self {
            FlightProfile::Level(p) => p.state_at(t),
            FlightProfile::PullUp(p) => p.state_at(t),
            FlightProfile::Turn(p) => p.state_at(t),
            FlightProfile::Recorded(p) => FlightPath::<T>::state_at(p, t),
        }
    }
}
