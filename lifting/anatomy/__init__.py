"""What a human body can be: adult limb lengths, and which way its hinges bend."""
