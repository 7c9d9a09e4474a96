//! The four blocks every scene holds: their size, number and colours.

/// Edge length of every block, metres.
pub const BLOCK_SIZE: f32 = 0.05;

/// Number of blocks in every scene.
pub const NUM_BLOCKS: usize = 4;

/// Block colours, RGB: red, blue, green, yellow.
pub const BLOCK_COLORS: [[u8; 3]; NUM_BLOCKS] =
    [[255, 87, 89], [78, 121, 167], [89, 161, 79], [237, 201, 72]];
