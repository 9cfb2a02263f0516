"""What flows through signcast: the avatar, motion, video I/O, segmentation."""
