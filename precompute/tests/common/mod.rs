//! Helpers shared by the test modules: the largest allocation a read makes, damaged copies of a
//! good file, and integrals and statistics over the sphere of directions.

pub mod alloc;
pub mod damage;
pub mod sphere;
