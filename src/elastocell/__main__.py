from elastocell.cli.app import main

main()
