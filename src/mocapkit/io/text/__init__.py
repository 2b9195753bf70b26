"""What every text reader shares: the number grammar, bounded input, and the plain time table."""
