"""twopose analysis: replay sessions through detection and solvers into error tables and reports."""
