"""What a person looks at: the Rerun recording and the run report."""
