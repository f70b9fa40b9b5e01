//! `twintrace view`: the interactive viewer's state, separate from any
//! window. A [`View`] holds a progressive render ([`crate::render`]) of a
//! scene from a camera the user moves ([`camera::ViewCamera`]); events
//! ([`Event`]) change the camera or the settings, and any change that
//! alters the image empties the film; each [`View::frame`] adds the next
//! samples to it, as many as hold the frame time.
//!
//! The film always holds sample indices `0..spp` of every pixel, so the
//! view's film after any sequence of frames is, bit for bit, the film a
//! `render` of `spp` samples from the same camera gives (`view --headless`
//! writes it, and the tests hold it to `render`).
//!
//! The view itself is in `session` (re-exported here); the window, its
//! panel, its saves and the twin comparison are the modules below, which
//! use it.

pub mod camera;
pub mod compare;
mod panel;
pub mod save;
mod session;
pub mod window;

pub use session::*;
