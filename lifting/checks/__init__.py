"""Is a lift a human body in a plausible world: bones, joints, floor, feet, and the words that say what is wrong."""
