from fogcli.cli import main

main()
