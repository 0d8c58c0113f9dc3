//! Distortion metrics (in progress).
