"""Checks of a constants set's claims: proven bounds of its forms, the fields of its file."""
