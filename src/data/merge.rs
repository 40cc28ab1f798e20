//! Merging experiments.
