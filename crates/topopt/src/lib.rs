//! # flexstage-topopt
//!
//! Workspace topology optimization (paper Section 2.2, Eq. 4–5, Algorithm 1).
