"""An example of a user's glove controller package, tested with exodigit's testing kit."""
