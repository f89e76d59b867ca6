//! One module per subcommand.

pub mod clean;
pub mod compaction;
pub mod compare;
pub mod compress;
pub mod convert;
pub mod decompress;
pub mod descriptors;
pub mod experiment;
pub mod info;
pub mod iterate;
pub mod operator;
pub mod partition;
pub mod project;
pub mod render;
pub mod repair;
pub mod smooth;
pub mod spectrum;
pub mod watermark;
