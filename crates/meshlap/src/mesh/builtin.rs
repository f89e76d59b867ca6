//! Built-in generated meshes.
