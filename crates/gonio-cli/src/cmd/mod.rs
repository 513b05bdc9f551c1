//! One module per subcommand.

pub mod acquire;
pub mod axis;
pub mod budget;
pub mod camera;
pub mod certificate;
pub mod compare;
pub mod demo;
pub mod detect;
pub mod eccentricity;
pub mod import;
pub mod joint;
pub mod mount;
pub mod parts;
pub mod replay;
pub mod report;
pub mod selfcal;
pub mod serve;
pub mod shift_angle;
pub mod simulate;
