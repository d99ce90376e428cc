"""What reads a photo: the face, the lips and the hair found in it, and the photo's light."""
