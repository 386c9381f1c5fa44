//! sphere (in progress)
