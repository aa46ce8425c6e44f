//! Errors: one small `Copy` enum for the whole core.
//!
//! Every fallible function returns [`Result`]. Nothing in the core panics on
//! caller input: bad input is an `Err` that names what was wrong and where.

use core::fmt;

/// Shorthand for `core::result::Result<T, sph_core::Error>`.
pub type Result<T> = core::result::Result<T, Error>;

/// What went wrong inside a time step (see [`Error::Unstable`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Fault {
    /// A field became NaN or infinite.
    NonFinite {
        /// `"velocity"`, `"position"`, `"density"`, `"acceleration"`, ...
        field: &'static str,
    },
    /// A speed exceeded the scene's limit (by default the sound speed: the
    /// weakly compressible model no longer holds, and the run is diverging).
    TooFast {
        /// The particle's speed.
        speed: f64,
        /// The limit it crossed.
        limit: f64,
    },
    /// A density fell to zero or below.
    NonPositiveDensity {
        /// The density.
        value: f64,
    },
    /// A particle went behind a shaped wall ([`crate::shape`]).
    BehindWall {
        /// Index of the wall.
        wall: usize,
        /// Its signed distance (negative: behind the wall).
        distance: f64,
    },
    /// A particle crossed a wall or left a non-periodic side of the domain.
    LeftDomain {
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// Its coordinate along that axis, relative to the domain's lower corner.
        coordinate: f64,
    },
}

/// Every error the core returns.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A caller-provided buffer is too small for what the scene needs.
    CapacityExceeded {
        /// Which buffer.
        buffer: &'static str,
        /// Entries needed.
        needed: usize,
        /// Entries available.
        available: usize,
    },
    /// Caller-provided slices that must have equal (or a required) length do not.
    LengthMismatch {
        /// Which buffer.
        buffer: &'static str,
        /// Length required.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A parameter is outside its valid range.
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// Its value (as `f64`; integers and flags are converted).
        value: f64,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// An input value is NaN or infinite.
    NonFinite {
        /// Index of the particle.
        particle: usize,
        /// `"position"`, `"velocity"`, `"mass"`, `"density"`, ...
        field: &'static str,
    },
    /// A particle lies outside the domain.
    OutsideDomain {
        /// Index of the particle.
        particle: usize,
        /// Axis (0 = x, 1 = y, 2 = z).
        axis: usize,
        /// Its coordinate along that axis, relative to the domain's lower corner.
        coordinate: f64,
    },
    /// A particle given to the solver lies behind a shaped wall.
    BehindWall {
        /// Index of the particle.
        particle: usize,
        /// Index of the wall.
        wall: usize,
        /// Its signed distance (negative).
        distance: f64,
    },
    /// A time step went wrong: the run is diverging or a particle escaped.
    Unstable {
        /// Index of the step that failed (the first step is 1).
        step: u64,
        /// Index of the first particle found at fault.
        particle: usize,
        /// What went wrong.
        fault: Fault,
    },
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Fault::NonFinite { field } => write!(f, "{field} is not finite"),
            Fault::TooFast { speed, limit } => {
                write!(f, "speed {speed:e} exceeds the limit {limit:e}")
            }
            Fault::NonPositiveDensity { value } => write!(f, "density {value:e} is not positive"),
            Fault::BehindWall { wall, distance } => {
                write!(f, "went behind shaped wall {wall} (distance {distance:e})")
            }
            Fault::LeftDomain { axis, coordinate } => {
                write!(
                    f,
                    "left the domain along axis {axis} (coordinate {coordinate:e})"
                )
            }
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::CapacityExceeded { buffer, needed, available } => write!(
                f,
                "capacity exceeded: `{buffer}` needs {needed} entries but has {available}"
            ),
            Error::LengthMismatch { buffer, expected, got } => write!(
                f,
                "length mismatch: `{buffer}` has length {got}, expected {expected}"
            ),
            Error::InvalidParameter { name, value, rule } => {
                write!(f, "invalid parameter `{name}` = {value}: {rule}")
            }
            Error::NonFinite { particle, field } => {
                write!(f, "particle {particle}: {field} is not finite")
            }
            Error::OutsideDomain { particle, axis, coordinate } => write!(
                f,
                "particle {particle} is outside the domain along axis {axis} (coordinate {coordinate:e})"
            ),
            Error::Unstable { step, particle, fault } => {
                write!(f, "unstable at step {step}: particle {particle}: {fault}")
            }
            Error::BehindWall { particle, wall, distance } => write!(
                f,
                "particle {particle} lies behind shaped wall {wall} (signed distance {distance:e}; the fluid is where it is positive)"
            ),
        }
    }
}

impl core::error::Error for Error {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::string::ToString;

    #[test]
    fn messages_name_what_and_where() {
        let e = Error::CapacityExceeded {
            buffer: "ghosts",
            needed: 12,
            available: 10,
        };
        assert_eq!(
            e.to_string(),
            "capacity exceeded: `ghosts` needs 12 entries but has 10"
        );
        let e = Error::InvalidParameter {
            name: "h",
            value: -1.0,
            rule: "must be positive",
        };
        assert_eq!(
            e.to_string(),
            "invalid parameter `h` = -1: must be positive"
        );
        let e = Error::Unstable {
            step: 7,
            particle: 3,
            fault: Fault::NonFinite { field: "velocity" },
        };
        assert_eq!(
            e.to_string(),
            "unstable at step 7: particle 3: velocity is not finite"
        );
        let e = Error::OutsideDomain {
            particle: 2,
            axis: 1,
            coordinate: -0.5,
        };
        assert!(e.to_string().contains("particle 2") && e.to_string().contains("axis 1"));
    }
}
