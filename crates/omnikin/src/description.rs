//! description (in progress)
