//! Mitsuba 3 scene files: the XML format ([`xml`]), the mesh files its
//! shapes read ([`meshes`]), and the scene they make ([`scene`]).
//! docs/mitsuba.md tables which plugins are read and how.

pub mod meshes;
pub mod scene;
pub mod spectra;
pub mod xml;

pub use scene::{build, load, EQUAL_ENERGY_RGB, NOT_SUPPORTED};
