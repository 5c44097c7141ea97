"""Controller design (thesis ch. 3): error dynamics with integral action, DLQR, feedforward."""
