//! Argument groups and printing helpers shared by the commands.

use meshlap::input::{self, Input, OpenOptions};
use meshlap::io::Format;
use serde::Serialize;

/// How to read a mesh argument.
#[derive(clap::Args, Debug, Clone)]
pub struct MeshArgs {
    /// Input mesh: a file (.obj .off .ply .stl) or builtin:NAME[:ARGS].
    pub mesh: String,
    /// Input format, overriding the extension (obj, off, ply, stl).
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<Format>,
}

impl MeshArgs {
    pub fn open(&self) -> meshlap::Result<Input> {
        input::open(
            &self.mesh,
            &OpenOptions {
                format: self.format,
                ..Default::default()
            },
        )
    }
}

/// Prints `value` as pretty JSON on stdout.
pub fn print_json<T: Serialize>(value: &T) -> meshlap::Result<()> {
    let s = serde_json::to_string_pretty(value)
        .map_err(|e| meshlap::Error::InvalidArgument(format!("cannot serialise output: {e}")))?;
    println!("{s}");
    Ok(())
}

/// Formats an optional float.
pub fn opt(v: Option<f64>) -> String {
    v.map_or("n/a".to_string(), |x| format!("{x:.6e}"))
}
