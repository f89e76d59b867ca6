//! One module per subcommand.

pub mod clean;
pub mod convert;
pub mod info;
pub mod iterate;
pub mod operator;
pub mod repair;
pub mod smooth;
pub mod experiment;
