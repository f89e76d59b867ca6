//! One module per subcommand.

pub mod clean;
pub mod convert;
pub mod info;
pub mod iterate;
pub mod operator;
pub mod partition;
pub mod render;
pub mod repair;
