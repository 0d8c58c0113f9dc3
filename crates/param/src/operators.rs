//! Operators used across organs (in progress).
