"""The "Match from photo" panel: panels, operators, properties, preferences, the thumbnail and the encoder's warm-up."""
