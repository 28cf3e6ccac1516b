//! Integrators and images (see the CLI issue).
