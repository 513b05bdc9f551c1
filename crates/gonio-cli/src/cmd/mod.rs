//! One module per subcommand.

pub mod budget;
pub mod demo;
pub mod eccentricity;
pub mod shift_angle;
pub mod simulate;
