//! Tools that measure the renderer rather than render: image metrics, convergence runs,
//! calibration of dual's density factors, the stability survey, lobe and fibersim images, and
//! the charts they draw.

pub mod calibrate;
pub mod compare;
pub mod converge;
pub mod lobe;
pub mod plot;
pub mod stability;
pub mod tables_chart;
