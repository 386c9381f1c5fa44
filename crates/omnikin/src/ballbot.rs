//! ballbot (in progress)
