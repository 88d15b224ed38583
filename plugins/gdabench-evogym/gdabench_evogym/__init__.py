"""Evolution Gym 2.0's tasks as gdabench environments."""
