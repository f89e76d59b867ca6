//! Mesh cleaning and validation.
