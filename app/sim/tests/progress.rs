//! The progress measure of every task on hand-placed block layouts (docs/design.md §2).

use seespot_sim::TaskId;
use seespot_sim::world::BlockPose;

fn up(x: f32, y: f32, level: usize) -> BlockPose {
    BlockPose::on_table(x, y, level, 0.0)
}

fn progress(task: TaskId, blocks: &[BlockPose]) -> u8 {
    task.progress(blocks)
}

#[test]
fn four_separate_blocks() {
    let b = [
        up(-0.15, -0.15, 0),
        up(0.15, -0.15, 0),
        up(-0.15, 0.15, 0),
        up(0.15, 0.15, 0),
    ];
    assert_eq!(progress(TaskId::Stack, &b), 1);
    assert_eq!(progress(TaskId::Unstack, &b), 4);
    assert_eq!(progress(TaskId::Row, &b), 1);
    assert_eq!(progress(TaskId::VerticalSquare, &b), 1);
}

#[test]
fn full_tower() {
    let b = [
        up(0.0, 0.0, 0),
        up(0.0, 0.0, 1),
        up(0.0, 0.0, 2),
        up(0.0, 0.0, 3),
    ];
    assert_eq!(progress(TaskId::Stack, &b), 4);
    assert_eq!(progress(TaskId::Unstack, &b), 1);
    assert_eq!(progress(TaskId::Row, &b), 1);
}

#[test]
fn tower_of_three_plus_a_loose_block() {
    let b = [
        up(0.0, 0.0, 0),
        up(0.01, 0.0, 1),
        up(0.0, 0.01, 2),
        up(0.15, 0.12, 0),
    ];
    assert_eq!(progress(TaskId::Stack, &b), 3);
    assert_eq!(progress(TaskId::Unstack, &b), 2);
    // The loose block is far from the tower: only the stack counts.
    assert_eq!(progress(TaskId::VerticalSquare, &b), 2);
}

#[test]
fn a_block_more_than_3cm_off_centre_is_not_on_the_tower() {
    let b = [
        up(0.0, 0.0, 0),
        up(0.035, 0.0, 1),
        up(0.15, 0.15, 0),
        up(-0.15, 0.15, 0),
    ];
    assert_eq!(progress(TaskId::Stack, &b), 1);
}

#[test]
fn row_of_four_and_partial_rows() {
    let row4 = [
        up(0.0, 0.0, 0),
        up(0.06, 0.0, 0),
        up(0.12, 0.0, 0),
        up(0.18, 0.0, 0),
    ];
    assert_eq!(progress(TaskId::Row, &row4), 4);
    let row3 = [
        up(0.0, 0.0, 0),
        up(0.06, 0.0, 0),
        up(0.12, 0.0, 0),
        up(0.0, 0.15, 0),
    ];
    assert_eq!(progress(TaskId::Row, &row3), 3);
}

#[test]
fn row_whose_gap_is_too_wide() {
    // 6 cm then 11 cm: only the first pair is a row.
    let b = [
        up(0.0, 0.0, 0),
        up(0.06, 0.0, 0),
        up(0.17, 0.0, 0),
        up(0.0, 0.18, 0),
    ];
    assert_eq!(progress(TaskId::Row, &b), 2);
    // Touching blocks (4.5 cm centre to centre) are too close.
    let b = [
        up(0.0, 0.0, 0),
        up(0.045, 0.0, 0),
        up(0.15, 0.15, 0),
        up(-0.15, 0.15, 0),
    ];
    assert_eq!(progress(TaskId::Row, &b), 1);
}

#[test]
fn diagonal_row() {
    let d = 0.07 / 2f32.sqrt();
    let b = [
        up(0.0, 0.0, 0),
        up(d, d, 0),
        up(2.0 * d, 2.0 * d, 0),
        up(3.0 * d, 3.0 * d, 0),
    ];
    assert_eq!(progress(TaskId::Row, &b), 4);
}

#[test]
fn crooked_and_uneven_rows_are_not_rows() {
    // The middle block 3 cm off the line.
    let b = [
        up(0.0, 0.0, 0),
        up(0.07, 0.045, 0),
        up(0.14, 0.0, 0),
        up(-0.15, 0.15, 0),
    ];
    assert!(progress(TaskId::Row, &b) < 3);
    // A block raised on another is at another height.
    let b = [
        up(0.0, 0.0, 0),
        up(0.07, 0.0, 1),
        up(0.14, 0.0, 0),
        up(0.07, 0.0, 0),
    ];
    assert!(progress(TaskId::Row, &b) <= 3);
}

#[test]
fn vertical_square_levels() {
    // Two 2-block towers side by side: done.
    let done = [
        up(0.0, 0.0, 0),
        up(0.0, 0.0, 1),
        up(0.07, 0.0, 0),
        up(0.07, 0.0, 1),
    ];
    assert_eq!(progress(TaskId::VerticalSquare, &done), 4);
    // Two 2-block towers that are not adjacent.
    let apart = [
        up(0.0, 0.0, 0),
        up(0.0, 0.0, 1),
        up(0.2, 0.0, 0),
        up(0.2, 0.0, 1),
    ];
    assert_eq!(progress(TaskId::VerticalSquare, &apart), 2);
    // One tower whose bottom forms a row with another block.
    let three = [
        up(0.0, 0.0, 0),
        up(0.0, 0.0, 1),
        up(0.07, 0.0, 0),
        up(-0.15, 0.15, 0),
    ];
    assert_eq!(progress(TaskId::VerticalSquare, &three), 3);
    // No stack, but a 2-block row.
    let row2 = [
        up(0.0, 0.0, 0),
        up(0.07, 0.0, 0),
        up(-0.15, 0.15, 0),
        up(0.15, 0.15, 0),
    ];
    assert_eq!(progress(TaskId::VerticalSquare, &row2), 2);
}

#[test]
fn tilted_block() {
    // A block leaning at 30 degrees, its centre 4 cm from a block's centre: not stacked.
    let q = seespot_sim::world::BlockPose {
        position: [0.04, 0.0, 0.04],
        rotation: {
            let (s, c) = (0.2618f32.sin(), 0.2618f32.cos());
            [0.0, s, 0.0, c]
        },
    };
    assert!(
        (q.tilt().to_degrees() - 30.0).abs() < 0.5,
        "tilt {}",
        q.tilt().to_degrees()
    );
    let b = [up(0.0, 0.0, 0), q, up(0.15, 0.15, 0), up(-0.15, 0.15, 0)];
    assert_eq!(progress(TaskId::Stack, &b), 1);
    // Raised 1.5 cm by its tilt, it is still within the row height band of a neighbour.
    let b = [
        up(0.0, 0.0, 0),
        BlockPose {
            position: [0.07, 0.0, 0.035],
            ..q
        },
        up(0.15, 0.15, 0),
        up(-0.15, -0.15, 0),
    ];
    assert_eq!(progress(TaskId::Row, &b), 2);
}
