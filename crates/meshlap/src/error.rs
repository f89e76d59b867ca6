//! The crate's top-level error type. Each module has its own typed error; this enum
//! wraps them so that applications can use one `Result`.

/// Every error meshlap can return.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading or writing a mesh file failed.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// The mesh is unsuitable for the requested operation.
    #[error(transparent)]
    Mesh(#[from] crate::mesh::MeshError),
    /// An operator could not be assembled.
    #[error(transparent)]
    Operator(#[from] crate::operator::OperatorError),
    /// A linear solve failed.
    #[error(transparent)]
    Solve(#[from] crate::solve::SolveError),
    /// A filter failed.
    #[error(transparent)]
    Filter(#[from] crate::filter::FilterError),
    /// A smoothing iteration `Hᵖx` could not run.
    #[error(transparent)]
    Smoothing(#[from] crate::analysis::smoothing::SmoothingError),
    /// Removing the SQL's negative weights failed.
    #[error(transparent)]
    Repair(#[from] crate::analysis::repair::RepairError),
    /// A spectral computation failed.
    #[error(transparent)]
    Spectral(#[from] crate::spectral::SpectralError),
    /// A patch-by-patch reconstruction failed.
    #[error(transparent)]
    Patchwise(#[from] crate::spectral::patchwise::PatchwiseError),
    /// Compression or decompression failed.
    #[error(transparent)]
    Codec(#[from] crate::codec::CodecError),
    /// Watermark embedding or detection failed.
    #[error(transparent)]
    Watermark(#[from] crate::watermark::WatermarkError),
    /// A distortion metric could not be computed.
    #[error(transparent)]
    Metric(#[from] crate::metric::MetricError),
    /// Partitioning a mesh into patches failed.
    #[error(transparent)]
    Partition(#[from] crate::partition::PartitionError),
    /// Heat or wave kernel signatures could not be computed.
    #[error(transparent)]
    Descriptor(#[from] crate::spectral::descriptors::DescriptorError),
    /// Rendering a chart failed.
    #[cfg(feature = "pictures")]
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    /// Rendering a mesh picture failed.
    #[cfg(feature = "pictures")]
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    /// An experiment failed.
    #[cfg(feature = "experiments")]
    #[error(transparent)]
    Experiment(#[from] crate::experiment::ExperimentError),
    /// A watermarking attack could not run.
    #[error(transparent)]
    Attack(#[from] crate::watermark::attack::AttackError),
    /// A user-supplied argument is invalid.
    #[error("{0}")]
    InvalidArgument(String),
}

/// `Result` with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
