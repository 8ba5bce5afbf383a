"""The Gymnasium surface: the environment, its vector form, its spaces, registration and rendering."""
