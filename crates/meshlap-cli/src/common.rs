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

/// A mesh to read and the file a command writes (`-o`).
#[derive(clap::Args, Debug, Clone)]
pub struct MeshInOut {
    #[command(flatten)]
    pub mesh: MeshArgs,
    /// Output file, written atomically (a mesh: format from the extension; `compress`
    /// writes .mlz, `render` .png).
    #[arg(long, short)]
    pub output: std::path::PathBuf,
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

/// A spinner on stderr for work that can take more than a second (hidden when stderr
/// is not a terminal).
pub fn spinner(msg: String) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new_spinner().with_message(msg);
    if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.enable_steady_tick(std::time::Duration::from_millis(120));
    } else {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar
}

/// A clap value parser for an option enum of the library: accepts exactly the
/// library's names (`T::ALL` mapped by `name`, listed in `--help`) and parses them
/// with the library's `FromStr`, so no value falls back silently.
pub fn one_of<T>(
    names: impl IntoIterator<Item = &'static str>,
) -> impl clap::builder::TypedValueParser<Value = T>
where
    T: std::str::FromStr + Clone + Send + Sync + 'static,
    T::Err: Into<Box<dyn std::error::Error + Send + Sync + 'static>>,
{
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(names).try_map(|s| s.parse::<T>())
}
