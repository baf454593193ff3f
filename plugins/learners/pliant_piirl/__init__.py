"""PIIRL sensitivity learning from demonstrations with active learning of the tasks to ask for (thesis ch. 4)."""
