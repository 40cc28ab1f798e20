//! Sampled time records.
