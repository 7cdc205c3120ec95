// Issue 5: to be written.
