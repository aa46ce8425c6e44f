//! Placeholder until the frontend lands.
