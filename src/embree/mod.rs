//! Safe binding to Embree (3 or 4). The only module with `unsafe`.
pub(crate) mod sys;
