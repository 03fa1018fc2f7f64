//! Goto has no overlay: it writes no notes, and a robot's arrival is in `trajectory.csv`
//! (the `reached` column), which the viewer reads itself.

use crate::overlay::Overlay;

impl Overlay for super::Goto {}
