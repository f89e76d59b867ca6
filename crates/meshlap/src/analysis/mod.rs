//! Matrix-theoretic analysis of operators (Zhang 2004 §2–3): the property report
//! (with the TL/GL spectrum comparison in [`operator_report`]),
//! smoothing iterations `Hᵖx`, and removal of the SQL's negative weights.

pub mod operator_report;
pub mod properties;
pub mod repair;
pub mod smoothing;
