//! Half-edge connectivity.
