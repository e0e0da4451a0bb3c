"""Print the shortest exactly verified frame period of the worst-case stress programs, 1 to 24 servos.

    .venv/bin/python benchmarks/stress.py

The programs and the search are in benchmarks/budget.py.
"""

import budget

if __name__ == "__main__":
    budget.main()
