from stlplan.cli import main

main()
