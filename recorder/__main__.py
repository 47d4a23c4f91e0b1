from recorder.cli.command import main

main()
