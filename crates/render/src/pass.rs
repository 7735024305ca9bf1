//! A pass of the frame plan, as `--explain` names it: its name and what it reads and writes.
//! The feature that records a pass defines it (the frame plan's own passes are in `frame.rs`,
//! each post-process's in its folder); the frame plan orders them.

use std::fmt;

#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Pass {
    name: &'static str,
    inputs: &'static str,
}

impl Pass {
    pub const fn new(name: &'static str, inputs: &'static str) -> Self {
        Self { name, inputs }
    }

    pub fn name(self) -> &'static str {
        self.name
    }

    /// What the pass reads (buffers, textures) and writes, for `penumbra render --explain`.
    pub fn inputs(self) -> &'static str {
        self.inputs
    }
}

impl fmt::Debug for Pass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name)
    }
}

impl fmt::Display for Pass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name)
    }
}
