//! caster (in progress)
