"""Command-line tools: forte_train_force, forte_evaluate_slip."""
