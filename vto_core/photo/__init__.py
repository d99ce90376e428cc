"""What reads a photo and draws on it: the face, the lips and the hair found in it, its light, the lipstick tried on."""
