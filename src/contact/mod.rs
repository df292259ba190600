//! Contact: the interpolation of contact-surface elements along their faces.
pub mod basis;
