//! Cross-crate integration tests of seespot live in `tests/tests/`: they drive the
//! block world, the policies and See-SPOT-Run together.
