//! Periodic records.
